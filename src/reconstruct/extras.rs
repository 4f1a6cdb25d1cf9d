//! Gaussians for what the body does not explain (hair beyond the scalp, loose clothing, a held
//! object): one for every person-mask pixel of the source view the (dressed) body does not cover,
//! with that pixel's colour, at the depth of the nearest body surface the view does see, bound to
//! that surface's triangle so it follows the animation.
//!
//! Each is a disc facing the source camera, one pixel wide, and as thick along the view as half
//! its distance from that surface (hair 6 cm above the scalp stands 3 cm deep, up to
//! [`MAX_DEPTH`]), so that from the side what was a sheet keeps some volume.

use glam::{Mat3A, Vec3};

use crate::avatar::{UvGaussians, quat_from_matrix, quat_mul};
use crate::body::TriangleFrame;
use crate::camera::Camera;
use crate::photo::SourceImage;
use crate::photo::distance::nearest_seeds;
use crate::raster::Fragments;

/// The thickest an extra Gaussian stands along the view (standard deviation, metres).
pub const MAX_DEPTH: f32 = 0.03;
/// Standard deviation of a disc across the view, in pixels of the source.
const RADIUS_PX: f32 = 0.6;
/// Extra Gaussians are opaque where the mask is sure, as the body's discs are.
const OPACITY: f32 = 0.95;
/// A pixel belongs to the person at this mask value.
const PERSON: f32 = 0.5;

/// Extra Gaussians for `photo`'s person pixels that `fragments` (the posed body's
/// rasterization from `camera`, the photo's size) leaves uncovered; `frames` are the posed
/// triangles' frames and `vertices`/`triangles` the posed mesh. Features: RGB and the mask value
/// as source confidence.
pub fn extras(
    photo: &SourceImage,
    fragments: &Fragments,
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    frames: &[TriangleFrame],
    camera: &Camera,
) -> UvGaussians {
    let mut out = UvGaussians::default();
    let Some(mask) = &photo.mask else {
        return out;
    };
    let size = photo.size as usize;
    let covered: Vec<bool> = fragments.triangle.iter().map(|&t| t >= 0).collect();
    let nearest = nearest_seeds(&covered, size);
    let world_from_view = Mat3A::from_mat4(camera.view_from_world.inverse());
    // The disc's axes: across the view (camera x and y), thin along it (axis 1 is the thin one,
    // as for the surface discs); columns (x, z, −y) keep it right-handed.
    let disc = quat_from_matrix(
        world_from_view * Mat3A::from_cols(Vec3::X.into(), Vec3::Z.into(), (-Vec3::Y).into()),
    );
    for (i, &m) in mask.iter().enumerate() {
        if m < PERSON || covered[i] {
            continue;
        }
        let Some((_, q)) = nearest[i] else { continue };
        let q = q as usize;
        let f = fragments.triangle[q] as usize;
        let frame = frames[f];
        if frame.scale.is_nan() || frame.scale <= 0.0 {
            continue;
        }
        let z = fragments.depth[q];
        let (x, y) = ((i % size) as f32 + 0.5, (i / size) as f32 + 0.5);
        let point = camera.unproject(x, y, z);
        let b = fragments.bary[q];
        let [v0, v1, v2] = triangles[f].map(|k| vertices[k as usize]);
        let anchor = b[0] * v0 + b[1] * v1 + b[2] * v2;
        let gap = camera.unproject((q % size) as f32 + 0.5, (q / size) as f32 + 0.5, z);
        let across = RADIUS_PX * camera.pixel_footprint(z);
        let along = (0.5 * point.distance(gap)).clamp(across, MAX_DEPTH);
        let to_local = frame.rotation.transpose();
        let triangle_rotation = quat_from_matrix(Mat3A::from(frame.rotation));
        let inverse = [
            triangle_rotation[0],
            -triangle_rotation[1],
            -triangle_rotation[2],
            -triangle_rotation[3],
        ];
        out.triangles.push(f as u32);
        out.barycentrics.push(b);
        out.offsets
            .push((to_local * (point - anchor) / frame.scale).to_array());
        out.local.rotations.push(quat_mul(inverse, disc));
        out.local
            .scales
            .push([across, along, across].map(|s| s / frame.scale));
        out.local.opacities.push(OPACITY * m.min(1.0));
        let (rgb, _) = photo.pixel(i);
        out.local.features.extend(
            rgb.map(|c| (c / m).min(1.0))
                .into_iter()
                .chain([m.min(1.0)]),
        );
    }
    out
}
