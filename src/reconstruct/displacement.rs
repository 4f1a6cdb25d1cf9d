//! The clothing layer: per-vertex offsets along the posed body's normals, fitted so that the
//! displaced body's silhouette from the source camera matches the person mask (the displacement
//! layer of SMPL+D, fitted to silhouettes as Alldieck et al. 2018 do), smooth and small where
//! nothing asks for them.
//!
//! Each round rasterizes the displaced body; every pixel on its silhouette asks the vertex it is
//! nearest to for the offset that moves the silhouette onto the mask's edge (the mask's signed
//! distance there, turned into metres at the pixel's depth and along the normal's part across
//! the view). The offsets then solve, by conjugate gradients, min Σ w (δ − target)² over those
//! vertices + [`BENDING`] |Lδ|² + [`SMOOTHING`] Σ_edges (δᵢ − δⱼ)² + Σ μ δ² (L the mesh's graph
//! Laplacian; μ large on the face, hands and eyes, which clothing does not cover, and
//! [`MAGNITUDE_PRIOR`] elsewhere), so what the silhouette asks of its sides spreads over the
//! front and back as a garment's thickness does. Welded vertices (UV-seam splits) share one
//! offset.

use glam::Vec3;

use crate::body::{BodyModel, PosedBody};
use crate::camera::Camera;
use crate::photo::Shown;
use crate::photo::distance::nearest_seeds;
use crate::raster::rasterize;

/// Offsets stay within these (metres): clothing stands off the body by up to 6 cm, and the
/// body may sink by 2 cm where the mask is narrower than the fitted body.
pub const MAX_OUT: f32 = 0.06;
pub const MAX_IN: f32 = 0.02;
/// How strongly offsets bend (thin-plate: the squared graph Laplacian of the offsets), and how
/// strongly neighbours agree (membrane), against one silhouette pixel's pull. Bending keeps the
/// silhouette's vertices from standing out of their neighbours as ridges.
const BENDING: f64 = 2.0;
const SMOOTHING: f64 = 0.2;
/// How strongly offsets stay at zero where nothing asks for them (per vertex).
const MAGNITUDE_PRIOR: f64 = 0.002;
/// Where clothing never is (face, ears, hands, eyes, mouth): offsets held at zero.
const BARE_PRIOR: f64 = 100.0;
/// The ears: head vertices this close to an ear landmark (metres, rest pose). Dressed out to
/// the hair beside them, their folds stretched into streaks that glowed beside the temples.
const EAR_RADIUS: f32 = 0.035;
/// Silhouette rounds (each re-rasterizes the displaced body).
const ROUNDS: usize = 3;
/// Conjugate-gradient steps per round at most; each round starts from the last one's offsets,
/// and a residual of 1e-3 of the targets' is a fraction of a millimetre.
const MAX_ITERATIONS: usize = 100;
/// A silhouette pixel further than this from the mask's edge is not the same outline (a limb the
/// fit put outside the person): it asks nothing.
const MAX_REACH_PX: f32 = 60.0;

/// What the solve did, for the report.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DisplacementReport {
    /// Silhouette pixels that asked for an offset in the last round.
    pub silhouette_pixels: usize,
    /// The largest offset out and in, metres.
    pub max_out: f32,
    pub max_in: f32,
}

/// Offsets (metres along the posed normal, one per vertex of `body`) that fit the silhouette of
/// `posed` seen by `camera` to `mask` (`camera.width`², values ≥ ½ the person) over the pixels
/// that show the photo (`shown`).
pub fn fit_displacements(
    body: &BodyModel,
    posed: &PosedBody,
    camera: &Camera,
    mask: &[f32],
    shown: Shown,
) -> (Vec<f32>, DisplacementReport) {
    let size = camera.width as usize;
    let groups = body.weld.iter().max().map_or(0, |&m| m as usize + 1);
    let neighbours = group_neighbours(body, groups);
    let inside = |v: usize| {
        let p = camera.project(posed.vertices[v]);
        p.z > 0.0 && shown.contains(p.x.floor() as i64, p.y.floor() as i64)
    };
    let prior = group_priors(body, groups, &neighbours, inside);
    let signed = signed_distance(mask, size);
    let mut offsets = vec![0.0f64; groups];
    let normals = body.normals_of(&posed.vertices);
    let mut report = DisplacementReport::default();
    for _ in 0..ROUNDS {
        let dressed: Vec<Vec3> = posed
            .vertices
            .iter()
            .zip(&normals)
            .zip(&body.weld)
            .map(|((v, n), &g)| *v + *n * offsets[g as usize] as f32)
            .collect();
        let f = rasterize(&dressed, &body.triangles, camera);
        // Per group: summed targets and their count.
        let mut asked = vec![(0.0f64, 0.0f64); groups];
        report.silhouette_pixels = 0;
        for y in 0..size {
            for x in 0..size {
                let i = y * size + x;
                let Ok(t) = usize::try_from(f.triangle[i]) else {
                    continue;
                };
                // The photo's edge is no outline: the body goes on past it.
                let outside = |dx: i64, dy: i64| {
                    let (u, v) = (x as i64 + dx, y as i64 + dy);
                    shown.contains(u, v) && f.triangle[v as usize * size + u as usize] < 0
                };
                let edge = [(-1, 0), (1, 0), (0, -1), (0, 1)]
                    .into_iter()
                    .filter(|&(dx, dy)| outside(dx, dy))
                    .fold((0.0f32, 0.0f32), |(ax, ay), (dx, dy)| {
                        (ax + dx as f32, ay + dy as f32)
                    });
                if edge == (0.0, 0.0) || signed[i].abs() > MAX_REACH_PX {
                    continue;
                }
                let b = f.bary[i];
                let corner = (0..3).fold(0, |m, k| if b[k] > b[m] { k } else { m });
                let v = body.triangles[t][corner] as usize;
                let n = normals[v];
                // The normal's part across the view, in the image: how far the outline moves
                // per metre of offset.
                let view = camera.view_from_world.transform_vector3(n);
                let across = (view.x * view.x + view.y * view.y).sqrt().max(0.3);
                // The outline lies half a pixel past this pixel's centre, the mask's edge half a
                // pixel past its last inside pixel's: the move onto it in pixels.
                let pixels = if signed[i] < 0.0 {
                    -signed[i] - 1.0
                } else {
                    -signed[i]
                };
                let metres = pixels * camera.pixel_footprint(f.depth[i]) / across;
                let g = body.weld[v] as usize;
                asked[g].0 += offsets[g] + metres as f64;
                asked[g].1 += 1.0;
                report.silhouette_pixels += 1;
            }
        }
        let targets: Vec<(f64, f64)> = asked
            .iter()
            .map(|&(sum, n)| {
                if n > 0.0 {
                    ((sum / n).clamp(-MAX_IN as f64, MAX_OUT as f64), n)
                } else {
                    (0.0, 0.0)
                }
            })
            .collect();
        offsets = solve(&neighbours, &prior, &targets, offsets);
        for o in &mut offsets {
            *o = o.clamp(-MAX_IN as f64, MAX_OUT as f64);
        }
    }
    let per_vertex: Vec<f32> = body
        .weld
        .iter()
        .map(|&g| offsets[g as usize] as f32)
        .collect();
    report.max_out = per_vertex.iter().copied().fold(0.0, f32::max);
    report.max_in = -per_vertex.iter().copied().fold(0.0, f32::min);
    (per_vertex, report)
}

/// Each welded group's neighbours over the mesh's edges, without repeats.
fn group_neighbours(body: &BodyModel, groups: usize) -> Vec<Vec<u32>> {
    let mut out: Vec<Vec<u32>> = vec![Vec::new(); groups];
    for t in &body.triangles {
        for k in 0..3 {
            let (a, b) = (body.weld[t[k] as usize], body.weld[t[(k + 1) % 3] as usize]);
            if a != b {
                out[a as usize].push(b);
                out[b as usize].push(a);
            }
        }
    }
    for n in &mut out {
        n.sort_unstable();
        n.dedup();
    }
    out
}

/// Each group's magnitude prior: [`BARE_PRIOR`] where any of its vertices is face, ear, hand, eye
/// or mouth, or lies outside the photo (`seen` is false: nothing there says what it wears), halving
/// with every edge away from them (so clothing tapers to a cuff or a collar over a few rings
/// instead of standing as a cliff), and never below [`MAGNITUDE_PRIOR`].
fn group_priors(
    body: &BodyModel,
    groups: usize,
    neighbours: &[Vec<u32>],
    seen: impl Fn(usize) -> bool,
) -> Vec<f64> {
    let head = body.joint_index("head").map(|j| body.joints[j].rest);
    let rest = body.landmark_positions(&body.vertices);
    let ears: Vec<Vec3> = body
        .landmarks
        .iter()
        .zip(&rest)
        .filter(|(l, _)| l.name.ends_with("_ear"))
        .map(|(_, &p)| p)
        .collect();
    let mut prior = vec![MAGNITUDE_PRIOR; groups];
    let mut ring = Vec::new();
    for (v, &g) in body.weld.iter().enumerate() {
        let bare = !seen(v)
            || match body.part_of(v) {
                Some("body") | Some("foot.L") | Some("foot.R") | None => false,
                // The face: the head's front below the hairline; the scalp may wear hair.
                Some("head") => {
                    let p = body.vertices[v];
                    head.is_some_and(|h| super::unseen_parts::on_face(h, p))
                        || ears.iter().any(|e| e.distance(p) < EAR_RADIUS)
                }
                Some(_) => true,
            };
        if bare && prior[g as usize] < BARE_PRIOR {
            prior[g as usize] = BARE_PRIOR;
            ring.push(g);
        }
    }
    let mut weight = BARE_PRIOR;
    while weight > MAGNITUDE_PRIOR && !ring.is_empty() {
        weight *= 0.5;
        let mut next = Vec::new();
        for &g in &ring {
            for &n in &neighbours[g as usize] {
                if prior[n as usize] < weight {
                    prior[n as usize] = weight;
                    next.push(n);
                }
            }
        }
        ring = next;
    }
    prior
}

/// The mask's signed distance in pixels, between pixel centres: positive outside the person (to
/// the nearest person pixel), negative inside (to the nearest pixel outside).
fn signed_distance(mask: &[f32], size: usize) -> Vec<f32> {
    let inside: Vec<bool> = mask.iter().map(|&m| m >= 0.5).collect();
    let outside: Vec<bool> = inside.iter().map(|&i| !i).collect();
    let to_inside = nearest_seeds(&inside, size);
    let to_outside = nearest_seeds(&outside, size);
    (0..size * size)
        .map(|i| {
            let d = |n: &Option<(f32, u32)>| n.map_or(size as f32, |(d2, _)| d2.sqrt());
            if inside[i] {
                -d(&to_outside[i])
            } else {
                d(&to_inside[i])
            }
        })
        .collect()
}

/// Conjugate gradients on (W + S·L + B·L² + M) δ = W t from `start`: W the targets' weights, L
/// the graph Laplacian of `neighbours`, M the priors; Jacobi-preconditioned.
fn solve(
    neighbours: &[Vec<u32>],
    prior: &[f64],
    targets: &[(f64, f64)],
    start: Vec<f64>,
) -> Vec<f64> {
    let n = neighbours.len();
    let laplacian =
        |x: &[f64], i: usize| -> f64 { neighbours[i].iter().map(|&j| x[i] - x[j as usize]).sum() };
    let mut lx = vec![0.0; n];
    let mut apply = |x: &[f64], out: &mut Vec<f64>| {
        for (i, l) in lx.iter_mut().enumerate() {
            *l = laplacian(x, i);
        }
        out.clear();
        out.extend((0..n).map(|i| {
            (targets[i].1 + prior[i]) * x[i] + SMOOTHING * lx[i] + BENDING * laplacian(&lx, i)
        }));
    };
    let diagonal: Vec<f64> = (0..n)
        .map(|i| {
            let degree = neighbours[i].len() as f64;
            targets[i].1 + prior[i] + SMOOTHING * degree + BENDING * (degree * degree + degree)
        })
        .collect();
    let rhs: Vec<f64> = targets.iter().map(|&(t, w)| w * t).collect();
    let mut x = start;
    let mut ax = Vec::with_capacity(n);
    apply(&x, &mut ax);
    let mut r: Vec<f64> = rhs.iter().zip(&ax).map(|(b, a)| b - a).collect();
    let mut z: Vec<f64> = r.iter().zip(&diagonal).map(|(r, d)| r / d).collect();
    let mut p = z.clone();
    let mut rz: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
    let norm = rhs.iter().map(|b| b * b).sum::<f64>().sqrt().max(1e-12);
    let mut ap = Vec::with_capacity(n);
    for _ in 0..MAX_ITERATIONS {
        if r.iter().map(|v| v * v).sum::<f64>().sqrt() < 1e-3 * norm {
            break;
        }
        apply(&p, &mut ap);
        let alpha = rz / p.iter().zip(&ap).map(|(a, b)| a * b).sum::<f64>();
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * ap[i];
            z[i] = r[i] / diagonal[i];
        }
        let rz_next: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
        let beta = rz_next / rz;
        rz = rz_next;
        for i in 0..n {
            p[i] = z[i] + beta * p[i];
        }
    }
    x
}
