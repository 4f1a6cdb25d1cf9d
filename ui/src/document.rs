//! What is open in the viewer — the splat scene, the body, the avatar, the motion, the networks
//! and the photo pipeline: what jobs load into and every view draws.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use guava::gaussians::GaussianCloud;
use guava::guava_mode::GuavaModels;
use guava::pipeline::Pipeline;

use crate::avatar_view::AvatarState;
use crate::body_panel::BodyState;
use crate::motion::Motion;

/// What is open in the viewer: what jobs load into and every view draws.
#[derive(Default)]
pub(crate) struct Document {
    pub scene: Option<Scene>,
    pub body: Option<BodyState>,
    pub avatar: Option<AvatarState>,
    /// The motion driving the body (the demo motion until another is opened).
    pub motion: Option<Motion>,
    /// GUAVA's networks, once the user opened their folder (GUAVA mode with an EHM body).
    pub networks: Option<Networks>,
    /// EHM-Tracker's keypoint models folder, once the user chose it: its DWPose places the body
    /// and hand points when photos are fitted.
    pub dwpose: Option<PathBuf>,
    /// Photo → avatar (keypoint models and the UV map kept between photos), shared with jobs.
    pub pipeline: Arc<Mutex<Pipeline>>,
}

pub(crate) struct Scene {
    pub name: String,
    /// Where it came from and what it is, shown in the panel (never "GUAVA avatar" unless it is one).
    pub kind: &'static str,
    pub cloud: Arc<GaussianCloud>,
    pub id: u64,
}

/// GUAVA mode's networks, shared with reconstruction workers (a session runs one call at a time).
pub(crate) struct Networks {
    pub models: Arc<Mutex<GuavaModels>>,
    /// The folder (its refiner refines GUAVA-mode avatars).
    pub dir: std::path::PathBuf,
    /// The folder and where its weights came from, shown in the panel.
    pub label: String,
}

impl Document {
    /// The name files made of the avatar are offered under: its photo's or file's stem.
    pub fn avatar_stem(&self) -> String {
        self.avatar
            .as_ref()
            .and_then(|a| std::path::Path::new(&a.avatar.source).file_stem())
            .map_or_else(|| "avatar".into(), |s| s.to_string_lossy().into_owned())
    }

    /// The timeline's time (0 without a motion).
    pub fn time(&self) -> f64 {
        self.motion.as_ref().map_or(0.0, |m| m.player.time())
    }
}
