//! The avatar being shown: its Gaussians rigged onto the current body pose (sliders or motion),
//! re-rigged only when the pose changed, as a scene for the splatting viewport.

use std::sync::Arc;

use guava::avatar::{Avatar, Rig};
use guava::gaussians::GaussianCloud;

use crate::body_panel::BodyState;
use crate::viewport::SceneRef;

pub struct AvatarState {
    pub avatar: Arc<Avatar>,
    /// What it is and where it came from, shown in the panel.
    pub label: String,
    rig: Rig,
    rigged_for: Option<u64>,
    scene: Option<SceneRef>,
}

impl AvatarState {
    pub fn new(avatar: Avatar, label: String) -> Self {
        Self {
            avatar: Arc::new(avatar),
            label,
            rig: Rig::default(),
            rigged_for: None,
            scene: None,
        }
    }

    /// The avatar on `body`'s current pose; a new scene generation (taken from `generation`)
    /// only when the pose changed.
    pub fn scene(&mut self, body: &mut BodyState, generation: &mut u64) -> Option<SceneRef> {
        let model = body.model.clone();
        let (posed, pose_generation) = body.posed();
        if self.rigged_for != Some(pose_generation) || self.scene.is_none() {
            let mut cloud = self
                .scene
                .take()
                .and_then(|s| Arc::try_unwrap(s.cloud).ok())
                .unwrap_or_else(|| GaussianCloud::new(self.avatar.channels));
            if let Err(e) = self
                .rig
                .animate(&self.avatar, posed, &model.triangles, &mut cloud)
            {
                log::error!("{e}");
                return None;
            }
            *generation += 1;
            self.scene = Some(SceneRef {
                generation: *generation,
                cloud: Arc::new(cloud),
            });
            self.rigged_for = Some(pose_generation);
        }
        self.scene.clone()
    }
}
