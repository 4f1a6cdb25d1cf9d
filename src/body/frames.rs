//! Per-triangle frames that carry GUAVA's UV Gaussians (reference:
//! `utils/graphics_utils.py:compute_face_orientation`, digested in notes/guava-pipeline.md §5).

use glam::{Mat3, Vec3};

/// Rotation R_t (columns: first-edge direction, normal, in-plane axis) and scale σ of a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleFrame {
    pub rotation: Mat3,
    /// Mean of the first edge's length and the triangle's height along the in-plane axis.
    pub scale: f32,
}

/// The reference's guard: lengths are sqrt(max(x·x, 1e-20)), so zero vectors normalise to zero.
const LENGTH_EPS: f32 = 1e-20;

fn length(x: Vec3) -> f32 {
    x.length_squared().max(LENGTH_EPS).sqrt()
}

fn normalize(x: Vec3) -> Vec3 {
    x / length(x)
}

/// Frames of every triangle, written into `out` (reused across frames).
///
/// Same operations and order as the reference, in f32. A degenerate triangle gets zero columns
/// where the reference does (finite, never NaN); callers treat a zero scale as "no frame".
pub fn triangle_frames(vertices: &[Vec3], triangles: &[[u32; 3]], out: &mut Vec<TriangleFrame>) {
    out.clear();
    out.extend(triangles.iter().map(|t| {
        let [v0, v1, v2] = t.map(|i| vertices[i as usize]);
        let a0 = normalize(v1 - v0);
        let a1 = normalize(a0.cross(v2 - v0));
        let a2 = -normalize(a1.cross(a0));
        let scale = (length(v1 - v0) + a2.dot(v2 - v0).abs()) / 2.0;
        TriangleFrame {
            rotation: Mat3::from_cols(a0, a1, a2),
            scale,
        }
    }));
}
