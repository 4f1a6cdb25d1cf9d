//! Pinhole cameras in GUAVA's axes (COLMAP/OpenCV: x right, y down, z forward), as the splatting
//! pass and the CPU reference consume them.
//!
//! Intrinsics use the pixel-edge convention: pixel `i` spans `[i, i+1)`, so the image centre of a
//! `W`-wide image is `W/2`. GUAVA's camera (`invtanfov = 24`, `utils/graphics_utils.py:get_proj_matrix`)
//! is `fx = fy = 24·W/2`, `cx = W/2`: the reference's `ndc2Pix` then puts a point at
//! `fx·x/z + cx − 0.5` in centre-at-integer pixel coordinates, which is what the rasterizer uses.

use glam::{Mat4, Vec3};

/// The reference rasterizer's near cull (`auxiliary.h:in_frustum`: `p_view.z <= 0.2`).
pub const REFERENCE_NEAR: f32 = 0.2;
/// GUAVA's `MODEL.invtanfov`: 1/tan(fov/2) for every camera.
pub const GUAVA_INVTANFOV: f32 = 24.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub view_from_world: Mat4,
    pub width: u32,
    pub height: u32,
    /// Focal lengths in pixels.
    pub fx: f32,
    pub fy: f32,
    /// Principal point in pixel-edge coordinates (`W/2` is the centre).
    pub cx: f32,
    pub cy: f32,
    /// Gaussians whose centre has view depth `z <= near` are culled.
    pub near: f32,
}

impl Camera {
    /// GUAVA's camera: square `size²` image, `tan(fov/2) = 1/invtanfov`, centred principal point.
    pub fn guava(view_from_world: Mat4, size: u32, invtanfov: f32) -> Self {
        let focal = invtanfov * size as f32 / 2.0;
        Self {
            view_from_world,
            width: size,
            height: size,
            fx: focal,
            fy: focal,
            cx: size as f32 / 2.0,
            cy: size as f32 / 2.0,
            near: REFERENCE_NEAR,
        }
    }

    /// GUAVA's camera (`tan(fov/2) = 1/invtanfov` across the square) on a `width × height`
    /// viewport: the square becomes the viewport's shorter side, centred.
    pub fn guava_in_viewport(
        view_from_world: Mat4,
        invtanfov: f32,
        width: u32,
        height: u32,
    ) -> Self {
        let focal = invtanfov * width.min(height) as f32 / 2.0;
        Self {
            view_from_world,
            width,
            height,
            fx: focal,
            fy: focal,
            cx: width as f32 / 2.0,
            cy: height as f32 / 2.0,
            near: REFERENCE_NEAR,
        }
    }

    /// Square pixels, vertical field of view `fov_y_rad`, any aspect.
    pub fn from_fov_y(view_from_world: Mat4, width: u32, height: u32, fov_y_rad: f32) -> Self {
        let fy = 0.5 * height as f32 / (0.5 * fov_y_rad).tan();
        Self {
            view_from_world,
            width,
            height,
            fx: fy,
            fy,
            cx: width as f32 / 2.0,
            cy: height as f32 / 2.0,
            near: REFERENCE_NEAR,
        }
    }

    /// The same view at `scale` times the resolution (at least 1×1): fewer pixels for the same
    /// picture.
    pub fn scaled(&self, scale: f32) -> Self {
        if scale == 1.0 {
            return *self;
        }
        let width = ((self.width as f32 * scale).round() as u32).max(1);
        let height = ((self.height as f32 * scale).round() as u32).max(1);
        let (sx, sy) = (
            width as f32 / self.width as f32,
            height as f32 / self.height as f32,
        );
        Self {
            width,
            height,
            fx: self.fx * sx,
            fy: self.fy * sy,
            cx: self.cx * sx,
            cy: self.cy * sy,
            ..*self
        }
    }

    /// View matrix looking from `eye` at `target`, `up` pointing up on screen (camera −y).
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Mat4 {
        let forward = (target - eye).normalize();
        let right = forward.cross(up).normalize();
        let down = forward.cross(right);
        // Rows of the rotation are the camera axes in world coordinates.
        let rot = Mat4::from_cols(
            right.extend(0.0),
            down.extend(0.0),
            forward.extend(0.0),
            glam::Vec4::W,
        )
        .transpose();
        rot * Mat4::from_translation(-eye)
    }

    /// 1/tan(fov/2) across the width: GUAVA's `invtanfov` of a square camera.
    pub fn invtanfov(&self) -> f32 {
        2.0 * self.fx / self.width as f32
    }

    /// A world point in pixel-edge coordinates (x, y) and its view depth z. Not clipped: callers
    /// test `z` against their own near limit.
    pub fn project(&self, world: Vec3) -> Vec3 {
        let p = self.view_from_world.transform_point3(world);
        Vec3::new(
            self.fx * p.x / p.z + self.cx,
            self.fy * p.y / p.z + self.cy,
            p.z,
        )
    }

    /// The world point at view depth `z` on the ray through pixel-edge coordinates (x, y): the
    /// inverse of [`Self::project`].
    pub fn unproject(&self, x: f32, y: f32, z: f32) -> Vec3 {
        let view = Vec3::new((x - self.cx) * z / self.fx, (y - self.cy) * z / self.fy, z);
        self.view_from_world.inverse().transform_point3(view)
    }

    /// Metres covered by one pixel at view depth `z` (the larger of the two axes).
    pub fn pixel_footprint(&self, z: f32) -> f32 {
        z / self.fx.min(self.fy)
    }

    /// The reference's EWA Jacobian clamp, `|x/z| ≤ 1.3·tan_fovx` (`forward.cu:computeCov2D`),
    /// generalised to off-centre principal points as gsplat does; equal to it when `cx = W/2`.
    /// Returns (x_neg, x_pos, y_neg, y_pos) as bounds on x/z and y/z.
    pub fn ewa_limits(&self) -> [f32; 4] {
        let tan_x = 0.5 * self.width as f32 / self.fx;
        let tan_y = 0.5 * self.height as f32 / self.fy;
        [
            self.cx / self.fx + 0.3 * tan_x,
            (self.width as f32 - self.cx) / self.fx + 0.3 * tan_x,
            self.cy / self.fy + 0.3 * tan_y,
            (self.height as f32 - self.cy) / self.fy + 0.3 * tan_y,
        ]
    }
}

/// A view that frames `cloud` (its finite centres' bounding sphere) for a vertical field of view,
/// orbiting its centre by `yaw` and `pitch` (radians) from the front: looking along +z with y
/// down, or, when `y_up`, at the front of a y-up body that faces +z ([`orbit_y_up`]).
pub fn orbit_view(
    cloud: &crate::gaussians::GaussianCloud,
    fov_y_rad: f32,
    yaw: f32,
    pitch: f32,
    y_up: bool,
) -> Option<Mat4> {
    let (lo, hi) = cloud.bounds()?;
    let centre = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-3);
    let distance = radius / (0.5 * fov_y_rad).sin();
    Some(if y_up {
        orbit_y_up(centre, distance, yaw, pitch)
    } else {
        orbit(centre, distance, yaw, pitch)
    })
}

/// [`orbit`] for a y-up world whose subject faces +z (body models): the world is turned half a
/// turn about x first, so yaw 0, pitch 0 faces the body's front with its head up.
pub fn orbit_y_up(target: Vec3, distance: f32, yaw: f32, pitch: f32) -> Mat4 {
    let flip = Mat4::from_diagonal(glam::Vec4::new(1.0, -1.0, -1.0, 1.0));
    orbit(flip.transform_point3(target), distance, yaw, pitch) * flip
}

/// Camera on a sphere around `target`; yaw about world −y (up), pitch towards it. Yaw 0, pitch 0
/// looks along +z, the GUAVA camera's direction.
pub fn orbit(target: Vec3, distance: f32, yaw: f32, pitch: f32) -> Mat4 {
    let dir = Vec3::new(
        yaw.sin() * pitch.cos(),
        -pitch.sin(),
        yaw.cos() * pitch.cos(),
    );
    Camera::look_at(target - dir * distance, target, Vec3::NEG_Y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guava_camera_matches_reference_pixel_formula() {
        // notes/guava-pipeline.md §2.3: x_pix = 6144·X/Z + 255.5 at 512².
        let cam = Camera::guava(Mat4::IDENTITY, 512, GUAVA_INVTANFOV);
        let (x, z) = (0.1_f32, 3.0_f32);
        let x_pix = cam.fx * x / z + cam.cx - 0.5;
        assert!((x_pix - (6144.0 * x / z + 255.5)).abs() < 1e-3);
        let lim = cam.ewa_limits();
        assert!(lim.iter().all(|l| (l - 1.3 / 24.0).abs() < 1e-6), "{lim:?}");
    }

    #[test]
    fn look_at_puts_target_on_the_optical_axis() {
        let view = Camera::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y);
        let t = view.transform_point3(Vec3::ZERO);
        assert!(t.x.abs() < 1e-5 && t.y.abs() < 1e-5 && t.z > 0.0, "{t}");
        // World up is screen up, i.e. camera −y.
        let up = view.transform_vector3(Vec3::Y);
        assert!(up.y < 0.0, "{up}");
    }
}
