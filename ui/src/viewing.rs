//! How the document is looked at: which view, the camera, the display and a split. Nothing here
//! changes what is open.

use guava::camera::Camera;
use guava::view::Display;

use crate::document::Document;
use crate::orbit::OrbitCamera;

/// What the viewport shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// The posed body template as a mesh.
    Body,
    /// The loaded Gaussian scene through the splatting pass.
    Gaussians,
    /// The avatar's Gaussians on the posed body, through the splatting pass.
    Avatar,
}

/// Where the viewport looks from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraMode {
    /// The orbit camera (mouse and sliders).
    Orbit,
    /// The camera of the photo the avatar was reconstructed from.
    Source,
    /// The motion's tracked camera at the current time.
    Tracked,
    /// The camera path keyed by hand, at the timeline's time.
    Keys,
}

/// How the viewport is drawn while the user drags, orbits or plays: at a fraction of its
/// resolution, back to full once input settles.
pub(crate) struct Interaction {
    /// The resolution scale while interacting (1 = always full).
    pub scale: f32,
    /// Whether the last frame was drawn at the interactive scale.
    pub active: bool,
}

/// How the document is looked at: none of it changes what is open.
pub(crate) struct Viewing {
    pub view: View,
    pub orbit: OrbitCamera,
    pub camera_mode: CameraMode,
    /// The camera path keyed by hand (camera mode *keys*, sequence exports).
    pub camera_keys: crate::camera_keys::CameraKeys,
    pub display: Display,
    /// A split between two views, and the mesh over the avatar.
    pub views: crate::compare::Views,
    /// Whether the avatar's photo is shown beside it in the viewport.
    pub display_photo_beside: bool,
    pub background: [f32; 3],
    pub interaction: Interaction,
}

impl Viewing {
    /// The body at the front, the orbit camera; `cpu`: a software adapter, which cannot splat
    /// the full viewport at interactive rates.
    pub fn new(cpu: bool) -> Self {
        Self {
            view: View::Body,
            orbit: OrbitCamera::default(),
            camera_mode: CameraMode::Orbit,
            camera_keys: Default::default(),
            display: Display::default(),
            views: Default::default(),
            display_photo_beside: false,
            background: [0.0; 3],
            interaction: Interaction {
                scale: if cpu { 0.5 } else { 1.0 },
                active: false,
            },
        }
    }

    /// Frames what the view shows with the orbit camera.
    pub fn frame(&mut self, doc: &mut Document) {
        let fov = self.orbit.fov_y_rad;
        match self.view {
            View::Gaussians => {
                if let Some(scene) = &doc.scene {
                    self.orbit = OrbitCamera::framing(&scene.cloud, fov);
                }
            }
            View::Body | View::Avatar => {
                if let Some(body) = &mut doc.body {
                    let (lo, hi) = body.bounds();
                    self.orbit = OrbitCamera {
                        y_up: true,
                        ..OrbitCamera::framing_box(lo, hi, fov)
                    };
                }
            }
        }
    }

    /// The orbit at one of [`crate::orbit::VIEWS`] (front, three-quarter, side, back), level.
    pub fn preset(&mut self, i: usize) {
        self.orbit.yaw_rad = crate::orbit::VIEWS[i].1.to_radians();
        self.orbit.pitch_rad = 0.0;
        self.camera_mode = CameraMode::Orbit;
    }

    /// The camera the viewport looks through at `width × height` pixels: a fixed camera (the
    /// photo's or the tracked one) when chosen and available, else the orbit.
    pub fn camera(&self, doc: &Document, width: u32, height: u32) -> Camera {
        let fixed = match self.camera_mode {
            CameraMode::Keys => {
                let keyed = self.camera_keys.at(doc.time());
                return keyed.unwrap_or(self.orbit).camera(width, height);
            }
            CameraMode::Orbit => None,
            CameraMode::Source => doc.avatar.as_ref().and_then(|a| a.source_camera),
            CameraMode::Tracked => doc.motion.as_ref().and_then(|m| m.camera()),
        };
        match fixed {
            Some((w2c, invtanfov)) => Camera::guava_in_viewport(w2c, invtanfov, width, height),
            None => self.orbit.camera(width, height),
        }
    }
}
