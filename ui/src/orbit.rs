//! Orbit camera controls for the viewport: drag to orbit, right/middle-drag to pan, scroll to zoom,
//! double-click to reframe. Produces the library's [`Camera`] for the splatting pass.

use glam::{Mat4, Vec3};
use guava::camera::{Camera, orbit, orbit_y_up};
use guava::gaussians::GaussianCloud;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    pub target: Vec3,
    pub distance: f32,
    pub yaw_rad: f32,
    pub pitch_rad: f32,
    pub fov_y_rad: f32,
    /// World +y is up (body models) rather than down (GUAVA/COLMAP cameras, most 3DGS scenes).
    pub y_up: bool,
}

impl Default for OrbitCamera {
    fn default() -> Self {
        Self {
            target: Vec3::ZERO,
            distance: 3.0,
            yaw_rad: 0.0,
            pitch_rad: 0.0,
            fov_y_rad: 50f32.to_radians(),
            y_up: false,
        }
    }
}

const PITCH_LIMIT: f32 = 1.55;

/// Orbit presets around the subject: its front, three-quarter, side and back (yaw, degrees).
pub const VIEWS: [(&str, f32); 4] = [
    ("Front", 0.0),
    ("Three-quarter", 35.0),
    ("Side", 90.0),
    ("Back", 180.0),
];

impl OrbitCamera {
    /// Frames the cloud's bounding sphere, keeping the field of view.
    pub fn framing(cloud: &GaussianCloud, fov_y_rad: f32) -> Self {
        match cloud.bounds() {
            Some((lo, hi)) => Self::framing_box(lo, hi, fov_y_rad),
            None => Self::default(),
        }
    }

    /// Frames the bounding sphere of the box `lo..hi`, keeping the field of view.
    pub fn framing_box(lo: Vec3, hi: Vec3, fov_y_rad: f32) -> Self {
        let radius = (0.5 * (hi - lo).length()).max(1e-3);
        Self {
            target: 0.5 * (lo + hi),
            distance: radius / (0.5 * fov_y_rad).sin(),
            fov_y_rad,
            ..Self::default()
        }
    }

    pub fn view_from_world(&self) -> Mat4 {
        if self.y_up {
            orbit_y_up(self.target, self.distance, self.yaw_rad, self.pitch_rad)
        } else {
            orbit(self.target, self.distance, self.yaw_rad, self.pitch_rad)
        }
    }

    pub fn camera(&self, width: u32, height: u32) -> Camera {
        Camera::from_fov_y(
            self.view_from_world(),
            width.max(1),
            height.max(1),
            self.fov_y_rad,
        )
    }

    /// Applies this frame's pointer input over the viewport.
    pub fn handle(&mut self, response: &egui::Response, ui: &egui::Ui) -> bool {
        let before = *self;
        let size = response.rect.size();
        if response.dragged_by(egui::PointerButton::Primary) {
            let d = response.drag_delta();
            self.yaw_rad -= d.x / size.x.max(1.0) * std::f32::consts::PI;
            self.pitch_rad = (self.pitch_rad - d.y / size.y.max(1.0) * std::f32::consts::PI)
                .clamp(-PITCH_LIMIT, PITCH_LIMIT);
        }
        if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
        {
            let d = response.drag_delta();
            // Pan in the image plane at the target's depth: one pixel covers this many world units.
            let units_per_px = 2.0 * self.distance * (0.5 * self.fov_y_rad).tan() / size.y.max(1.0);
            let world_from_view = self.view_from_world().inverse();
            let right = world_from_view.transform_vector3(Vec3::X);
            let down = world_from_view.transform_vector3(Vec3::Y);
            self.target -= (right * d.x + down * d.y) * units_per_px;
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.distance = (self.distance * (-scroll * 0.002).exp()).clamp(1e-3, 1e6);
            }
        }
        *self != before
    }
}
