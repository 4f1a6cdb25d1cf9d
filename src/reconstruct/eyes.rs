//! The eyes at the photo's resolution (default mode). The UV map gives each eyeball's front a
//! handful of texels (Anny's layout: about six across at 448²), so an open eye drew as one pale
//! smear with no iris or pupil. Each triangle of an eyeball's front is also sampled on a finer
//! lattice, about a photo pixel apart, and every lattice point the photo shows becomes a small
//! disc of its colour just in front of the coarse discs, riding its triangle as they do; where
//! the photo does not show the eyeball (under the lids) the disc takes the eye's guess
//! ([`super::unseen_parts::EyeGuess`]: an eye looking straight ahead), so an avatar opening its
//! eyes wider than the photo did shows an eye there. A photo that shows the eyes a few pixels
//! wide (a whole body) gets none: the map already holds what it shows.

use glam::Vec3;

use super::default_mode::DiscStyle;
use super::texture::Sampler;
use super::unseen_parts::EyeGuess;
use crate::avatar::UvGaussians;
use crate::body::{BodyModel, triangle_frames};

/// The parts sampled finely: the eyeballs' fronts.
const FINE_PARTS: [&str; 2] = ["eye_front.L", "eye_front.R"];
/// Each triangle's edges are cut about one photo pixel apart (its longest edge's length in the
/// photo, rounded up), at most this many times; one disc at each sub-triangle's centre.
const MAX_SUBDIVISIONS: usize = 8;
/// How far the fine discs stand in front of the coarse ones along the normal (metres): enough
/// to be drawn over them, far less than a lid is thick.
const LIFT: f32 = 2e-4;

/// Barycentric centres of the sub-triangles of a triangle cut `n` times along each edge.
fn lattice(n: usize) -> Vec<[f32; 3]> {
    let n_f = n as f32;
    let mut out = Vec::with_capacity(n * n);
    for (third, rows) in [(1.0 / 3.0, n), (2.0 / 3.0, n.saturating_sub(1))] {
        for i in 0..rows {
            for j in 0..rows - i {
                let (a, b) = ((i as f32 + third) / n_f, (j as f32 + third) / n_f);
                out.push([a, b, 1.0 - a - b]);
            }
        }
    }
    out
}

/// One point of an eyeball's fine lattice: where it lies, the disc it would be, and what the
/// photo shows there.
struct FinePoint {
    triangle: u32,
    barycentric: [f32; 3],
    /// The point on the body at rest (where a guessed eye is coloured).
    rest: Vec3,
    /// The eyeball's front part.
    part: &'static str,
    radius: f32,
    /// The lift along the triangle's normal, towards the camera, in the triangle's frame.
    lift: f32,
    /// The photo's colour and confidence, `None` where it does not show the point.
    seen: Option<([f32; 3], f32)>,
}

/// The eyeballs' fronts on a lattice about a photo pixel apart, each point sampled from the
/// photo ([`sample_eyes`]).
pub(super) struct FineEyes {
    points: Vec<FinePoint>,
}

/// Samples the eyeballs' fronts of `body` posed at `vertices` on their fine lattice where
/// `sampler` (the photo seen from its camera) shows them; the discs' radius from `style`.
pub(super) fn sample_eyes(
    body: &BodyModel,
    vertices: &[Vec3],
    sampler: &Sampler,
    style: &DiscStyle,
) -> FineEyes {
    let (ids, tris): (Vec<usize>, Vec<[u32; 3]>) = body
        .triangles
        .iter()
        .enumerate()
        .filter(|(_, tri)| {
            tri.iter().all(|&v| {
                body.part_of(v as usize)
                    .is_some_and(|p| FINE_PARTS.contains(&p))
            })
        })
        .unzip();
    let mut frames = Vec::new();
    triangle_frames(vertices, &tris, &mut frames);
    let lattices: Vec<Vec<[f32; 3]>> = (0..=MAX_SUBDIVISIONS).map(lattice).collect();
    let mut points = Vec::new();
    for ((&t, tri), frame) in ids.iter().zip(&tris).zip(&frames) {
        let part = body
            .part_of(tri[0] as usize)
            .and_then(|p| FINE_PARTS.iter().find(|&&f| f == p));
        let Some(&part) = part else { continue };
        if frame.scale <= 0.0 {
            continue;
        }
        let corners = tri.map(|v| vertices[v as usize]);
        let pixels = corners.map(|p| sampler.pixel(p));
        let longest = |edge: &dyn Fn(usize) -> f32| (0..3).map(edge).fold(0.0f32, f32::max);
        let in_photo = longest(&|k| pixels[k].distance(pixels[(k + 1) % 3]));
        let n = (in_photo.ceil() as usize).min(MAX_SUBDIVISIONS);
        if n < 2 {
            continue;
        }
        let metres = longest(&|k| corners[k].distance(corners[(k + 1) % 3]));
        let radius = style.radius * metres / n as f32 / frame.scale;
        let normal = frame.rotation.y_axis;
        for &b in &lattices[n] {
            let p: Vec3 = (0..3).map(|k| b[k] * corners[k]).sum();
            let towards = normal.dot(sampler.eye() - p).signum();
            points.push(FinePoint {
                triangle: t as u32,
                barycentric: b,
                rest: (0..3).map(|k| b[k] * body.vertices[tri[k] as usize]).sum(),
                part,
                radius,
                lift: towards * LIFT / frame.scale,
                seen: sampler.sample(t as u32, p),
            });
        }
    }
    FineEyes { points }
}

impl FineEyes {
    /// The fine discs: where the photo shows the point, of its colour; where it does not, of its
    /// eye's guess among `guessed` (source confidence 0); with the default reconstruction's
    /// features (RGB, then the source confidence).
    pub(super) fn discs(&self, guessed: &[EyeGuess], style: &DiscStyle) -> UvGaussians {
        let mut out = UvGaussians::default();
        for point in &self.points {
            let guess = || {
                let eye = guessed.iter().find(|g| g.part == point.part)?;
                Some((eye.at(point.rest), 0.0))
            };
            let Some((rgb, confidence)) = point.seen.or_else(guess) else {
                continue;
            };
            out.triangles.push(point.triangle);
            out.barycentrics.push(point.barycentric);
            out.offsets.push([0.0, point.lift, 0.0]);
            out.local.rotations.push([1.0, 0.0, 0.0, 0.0]);
            out.local
                .scales
                .push([point.radius, style.thickness * point.radius, point.radius]);
            out.local.opacities.push(style.opacity);
            out.local.features.extend(rgb);
            out.local.features.push(confidence);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lattice fills the triangle evenly: n² points, all inside, their mean its centroid.
    #[test]
    fn the_lattice_is_n_squared_points_inside_the_triangle() {
        for n in [1, 2, 8] {
            let points = lattice(n);
            assert_eq!(points.len(), n * n);
            assert!(points.iter().all(|b| b.iter().all(|&x| x > 0.0 && x < 1.0)));
            let mean = points
                .iter()
                .fold([0.0f32; 3], |m, b| [m[0] + b[0], m[1] + b[1], m[2] + b[2]])
                .map(|x| x / points.len() as f32);
            assert!(
                mean.iter().all(|&x| (x - 1.0 / 3.0).abs() < 1e-5),
                "{mean:?}"
            );
        }
    }
}
