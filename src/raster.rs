//! A z-buffer rasterizer for triangle meshes on the CPU: which triangle covers each pixel, where
//! on it, and how far away. Reconstruction uses it for visibility from the source camera; the
//! synthetic-photo generator uses it to draw a textured body.
//!
//! Pixel centres are at `i + 0.5` in the camera's pixel-edge coordinates (the same centres the
//! splatting pass shades). No back-face culling (the reference's `cull_backfaces=False`);
//! barycentrics and depth are perspective-correct.

use crate::camera::Camera;
use glam::{Vec2, Vec3};

/// Triangles with a corner nearer than this (metres, view z) are left out rather than clipped:
/// a camera inside the avatar then sees past the triangles at its eye instead of dividing by ~0.
pub const RASTER_NEAR: f32 = 1e-3;

/// Per pixel: the nearest triangle (or −1), its perspective-correct barycentrics and view depth.
#[derive(Clone, Debug)]
pub struct Fragments {
    pub width: u32,
    pub height: u32,
    pub triangle: Vec<i32>,
    pub bary: Vec<[f32; 3]>,
    /// View-space z of the visible surface; `f32::INFINITY` where no triangle covers the pixel.
    pub depth: Vec<f32>,
}

impl Fragments {
    pub fn index(&self, x: u32, y: u32) -> usize {
        (y * self.width + x) as usize
    }

    /// Covered pixels as a 0/1 mask (the body's silhouette).
    pub fn coverage(&self) -> Vec<f32> {
        self.triangle
            .iter()
            .map(|&t| if t >= 0 { 1.0 } else { 0.0 })
            .collect()
    }
}

/// Rasterizes `triangles` over `vertices` (world space) as seen by `camera`.
pub fn rasterize(vertices: &[Vec3], triangles: &[[u32; 3]], camera: &Camera) -> Fragments {
    let (w, h) = (camera.width, camera.height);
    let n = w as usize * h as usize;
    let mut out = Fragments {
        width: w,
        height: h,
        triangle: vec![-1; n],
        bary: vec![[0.0; 3]; n],
        depth: vec![f32::INFINITY; n],
    };
    fragments(vertices, triangles, camera, |t, i, z, bary| {
        if z < out.depth[i] {
            out.depth[i] = z;
            out.triangle[i] = t as i32;
            out.bary[i] = bary;
        }
    });
    out
}

/// View-space z of the farthest surface of `triangles` over `vertices` at each pixel `camera`
/// sees (the back of what [`rasterize`] sees the front of); `f32::NEG_INFINITY` where none is.
pub fn farthest(vertices: &[Vec3], triangles: &[[u32; 3]], camera: &Camera) -> Vec<f32> {
    let mut depth = vec![f32::NEG_INFINITY; camera.width as usize * camera.height as usize];
    fragments(vertices, triangles, camera, |_, i, z, _| {
        depth[i] = depth[i].max(z);
    });
    depth
}

/// Calls `f(triangle, pixel, view z, perspective-correct barycentrics)` for every pixel centre
/// each triangle in front of the camera covers.
fn fragments(
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    camera: &Camera,
    mut f: impl FnMut(usize, usize, f32, [f32; 3]),
) {
    let (w, h) = (camera.width, camera.height);
    let projected: Vec<Vec3> = vertices.iter().map(|&v| camera.project(v)).collect();
    for (t, tri) in triangles.iter().enumerate() {
        let p = tri.map(|i| projected[i as usize]);
        if p.iter().any(|q| !q.is_finite() || q.z <= RASTER_NEAR) {
            continue;
        }
        let inv_z = p.map(|q| 1.0 / q.z);
        let corners = p.map(|q| Vec2::new(q.x, q.y));
        cover(corners, w, h, |x, y, l| {
            let z = 1.0 / (l[0] * inv_z[0] + l[1] * inv_z[1] + l[2] * inv_z[2]);
            f(
                t,
                (y * w + x) as usize,
                z,
                [0, 1, 2].map(|k| l[k] * inv_z[k] * z),
            );
        });
    }
}

/// Calls `f(x, y, barycentrics)` for every pixel of a `width × height` grid whose centre
/// (x + ½, y + ½) lies in the 2D triangle `p` (either winding, edges included), with the centre's
/// barycentrics. Degenerate and non-finite triangles cover nothing.
pub(crate) fn cover(p: [Vec2; 3], width: u32, height: u32, mut f: impl FnMut(u32, u32, [f32; 3])) {
    let area = (p[1] - p[0]).perp_dot(p[2] - p[0]);
    if area == 0.0 || !area.is_finite() {
        return;
    }
    let lo = p[0].min(p[1]).min(p[2]);
    let hi = p[0].max(p[1]).max(p[2]);
    // Pixels whose centre lies in [lo, hi].
    let x0 = (lo.x - 0.5).ceil().max(0.0) as u32;
    let y0 = (lo.y - 0.5).ceil().max(0.0) as u32;
    let x1 = (hi.x - 0.5).floor().min(width as f32 - 1.0);
    let y1 = (hi.y - 0.5).floor().min(height as f32 - 1.0);
    if x1 < 0.0 || y1 < 0.0 {
        return;
    }
    for y in y0..=y1 as u32 {
        for x in x0..=x1 as u32 {
            let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            // The same sign as the area means inside.
            let l0 = (p[2] - p[1]).perp_dot(q - p[1]) / area;
            let l1 = (p[0] - p[2]).perp_dot(q - p[2]) / area;
            let l2 = 1.0 - l0 - l1;
            if l0 >= 0.0 && l1 >= 0.0 && l2 >= 0.0 {
                f(x, y, [l0, l1, l2]);
            }
        }
    }
}
