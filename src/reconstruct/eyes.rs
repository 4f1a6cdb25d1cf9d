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

/// The fine discs of the eyeballs' fronts on `body` posed at `vertices`: where `sampler` (the
/// photo seen from its camera) shows a lattice point, of its colour; where it does not, of its
/// eye's guess among `guessed` (source confidence 0); with the default reconstruction's features
/// (RGB, then the source confidence).
pub(super) fn fine_eyes(
    body: &BodyModel,
    vertices: &[Vec3],
    sampler: &Sampler,
    guessed: &[EyeGuess],
    style: &DiscStyle,
) -> UvGaussians {
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
    let mut out = UvGaussians::default();
    for ((&t, tri), frame) in ids.iter().zip(&tris).zip(&frames) {
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
        let part = body.part_of(tri[0] as usize);
        let eye = guessed.iter().find(|g| Some(g.part) == part);
        for &b in &lattices[n] {
            let p: Vec3 = (0..3).map(|k| b[k] * corners[k]).sum();
            // Where the photo does not show the point, the guess at its place at rest.
            let guess = || {
                let rest = (0..3).map(|k| b[k] * body.vertices[tri[k] as usize]).sum();
                Some((eye?.at(rest), 0.0))
            };
            let Some((rgb, confidence)) = sampler.sample(t as u32, p).or_else(guess) else {
                continue;
            };
            let towards = normal.dot(sampler.eye() - p).signum();
            out.triangles.push(t as u32);
            out.barycentrics.push(b);
            out.offsets.push([0.0, towards * LIFT / frame.scale, 0.0]);
            out.local.rotations.push([1.0, 0.0, 0.0, 0.0]);
            out.local
                .scales
                .push([radius, style.thickness * radius, radius]);
            out.local.opacities.push(style.opacity);
            out.local.features.extend(rgb);
            out.local.features.push(confidence);
        }
    }
    out
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
