//! The silhouette stage: after the keypoint stages, the body's outline is fitted to the person
//! mask, so shape and pose explain where the person is and not only where the keypoints are.
//!
//! Iterative closest points in the image, each round from the body as the last left it: every
//! (sampled) pixel of the body's outline is matched to the nearest pixel of the mask's outline,
//! and every (sampled) pixel of the mask's outline to the nearest of the body's; each match pulls
//! that surface point (a triangle and barycentrics, posed like a landmark) onto its pixel. The
//! body keypoints and face points stay in at their weights, the outline's matches together weigh
//! as much as the body keypoints, and the stage moves the global orientation, the camera, the
//! spine and the shape, with the body stage's priors. A match further than [`MAX_MATCH_PX`] is
//! left out: that is not the same outline. What the body's outline still misses of the mask the
//! clothing layer and the Gaussians beyond the body take (`crate::reconstruct`).

use glam::{Vec2, Vec3};

use super::problem::{FitState, Stage, Target, Unknown, camera_for};
use super::unknowns::{joint_unknowns, root_and_camera};
use super::{FitReport, ITERATIONS, SHAPE_PRIOR_PX};
use crate::body::{BodyModel, BodyPose, Landmark, PointPoser, PosedBody, TargetGroup};
use crate::photo::distance::nearest_seeds;
use crate::raster::rasterize;
use crate::tracking::SourceView;

/// Rounds of matching and solving, at most: a body 28 px off its outline (another shape, turned
/// 0.25 rad) comes within 5.6 px in 2 rounds, 2.2 px in 4 and 1.6 px in 6 (tests/fidelity.rs).
const ROUNDS: usize = 6;
/// A round that brings the outlines less than this much closer (mean, pixels) is the last.
const CONVERGED_PX: f32 = 0.25;
/// Outline pixels sampled on each side per round.
const SAMPLES: usize = 150;
/// Matches further apart than this are not the same outline.
const MAX_MATCH_PX: f32 = 60.0;
/// The joint the silhouette turns besides the root. Limbs stay where the keypoints put them:
/// matched to a mask that wraps them in a suit's bulk, outline points pulled forearms across the
/// chest (the demo portrait's badge smeared over them: PSNR 20.6 → 19.6 dB with the arms moved).
const SPINE: &str = "spine03";

/// What the silhouette stage did.
#[derive(Clone, Debug, PartialEq)]
pub struct SilhouetteReport {
    /// Mean distance between matched outline pixels before and after, in pixels.
    pub before_px: f32,
    pub after_px: f32,
    /// Intersection over union of the body's silhouette and the mask before and after.
    pub iou_before: f32,
    pub iou_after: f32,
}

/// Which pixels the posed body covers, and for each the triangle and barycentrics seen there.
struct Coverage {
    covered: Vec<bool>,
    surface: Vec<(usize, [f32; 3])>,
}

/// Fits `view` (the keypoint stages' answer on `body`, with `report` holding what they
/// observed) to `mask` (`side`², values ≥ ½ the person). The camera keeps GUAVA's intrinsics.
pub fn fit_silhouette(
    body: &BodyModel,
    view: &SourceView,
    report: &FitReport,
    mask: &[f32],
    side: u32,
) -> (SourceView, SilhouetteReport) {
    let size = side as usize;
    let person: Vec<bool> = mask.iter().map(|&m| m >= 0.5).collect();
    let mask_edge = outline(&person, size);
    let to_mask_edge = nearest_seeds(&mask_edge, size);
    let mut state = FitState::of_view(view);
    let mut unknowns: Vec<(Unknown, f64)> = root_and_camera().collect();
    if let Some(j) = body.joint_index(SPINE) {
        unknowns.extend(joint_unknowns(body, j));
    }
    unknowns.extend(
        body.targets_in(TargetGroup::Shape)
            .map(|(i, t)| (Unknown::Coefficient(i, t.range), SHAPE_PRIOR_PX)),
    );
    // The keypoint stages' points stay in: body keypoints at 1, face points at ½.
    let mut fixed: Vec<(Landmark, Vec2, f64)> = report
        .surface
        .iter()
        .cloned()
        .zip(report.observed.iter().copied())
        .map(|(l, p)| (l, p, 1.0))
        .collect();
    if let Some(face) = &report.face {
        fixed.extend(
            face.surface
                .iter()
                .cloned()
                .zip(face.observed.iter().copied())
                .map(|(l, p)| (l, p, 0.5)),
        );
    }
    let keypoint_weight = report.surface.len() as f64;
    let measure = |pose: &BodyPose, camera: Vec3| -> Option<Coverage> {
        let mut posed = PosedBody::default();
        body.pose(pose, &mut posed).ok()?;
        let f = rasterize(&posed.vertices, &body.triangles, &camera_for(camera, side));
        Some(Coverage {
            covered: f.triangle.iter().map(|&t| t >= 0).collect(),
            surface: (0..size * size)
                .map(|i| (f.triangle[i].max(0) as usize, f.bary[i]))
                .collect(),
        })
    };
    let iou = |covered: &[bool]| {
        let both = covered
            .iter()
            .zip(&person)
            .filter(|(c, p)| **c && **p)
            .count();
        let either = covered
            .iter()
            .zip(&person)
            .filter(|(c, p)| **c || **p)
            .count();
        both as f32 / either.max(1) as f32
    };
    let mut silhouette = SilhouetteReport {
        before_px: 0.0,
        after_px: 0.0,
        iou_before: 0.0,
        iou_after: 0.0,
    };
    for round in 0..=ROUNDS {
        let Some(Coverage { covered, surface }) = measure(&state.pose, state.camera) else {
            break;
        };
        let body_edge = outline(&covered, size);
        let to_body_edge = nearest_seeds(&body_edge, size);
        let mut matches: Vec<(Landmark, Vec2)> = Vec::new();
        let mut distance = 0.0;
        let pixel = |i: usize| Vec2::new((i % size) as f32 + 0.5, (i / size) as f32 + 0.5);
        let on_surface = |i: usize| {
            let (t, b) = surface[i];
            Landmark {
                name: String::new(),
                vertices: body.triangles[t].to_vec(),
                weights: b.to_vec(),
            }
        };
        for (from_body, from, to) in [
            (true, &body_edge, &to_mask_edge),
            (false, &mask_edge, &to_body_edge),
        ] {
            let ends: Vec<usize> = (0..size * size).filter(|&i| from[i]).collect();
            let step = ends.len().div_ceil(SAMPLES).max(1);
            for &i in ends.iter().step_by(step) {
                let Some((d2, j)) = to[i] else { continue };
                if d2.sqrt() > MAX_MATCH_PX {
                    continue;
                }
                let j = j as usize;
                distance += d2.sqrt();
                // The body's point goes to the mask's pixel, whichever side was sampled.
                let (body_pixel, mask_pixel) = if from_body { (i, j) } else { (j, i) };
                matches.push((on_surface(body_pixel), pixel(mask_pixel)));
            }
        }
        let mean = distance / matches.len().max(1) as f32;
        if round == 0 {
            (silhouette.before_px, silhouette.iou_before) = (mean, iou(&covered));
        }
        let converged = round > 0 && silhouette.after_px - mean < CONVERGED_PX;
        (silhouette.after_px, silhouette.iou_after) = (mean, iou(&covered));
        if round == ROUNDS || matches.is_empty() || converged {
            break;
        }
        let weight = (keypoint_weight / matches.len() as f64).sqrt();
        let landmarks: Vec<Landmark> = fixed
            .iter()
            .map(|(l, ..)| l.clone())
            .chain(matches.iter().map(|(l, _)| l.clone()))
            .collect();
        let mut poser = PointPoser::new(body, &landmarks);
        let observations = fixed
            .iter()
            .map(|(_, p, w)| (*p, *w))
            .chain(matches.iter().map(|(_, p)| (*p, weight)))
            .enumerate()
            .map(|(k, (p, w))| (Target::Point(k), p, w))
            .collect::<Vec<_>>();
        let mut stage = Stage {
            body,
            side,
            poser: &mut poser,
            features: vec![None; observations.len()],
            observations,
            pixels: Vec::new(),
            unknowns: unknowns.clone(),
            antagonists: Vec::new(),
            temporal: Vec::new(),
            iterations: ITERATIONS,
            base: state.clone(),
            relaxed: view.pose.clone(),
            points: Vec::new(),
            joints: Vec::new(),
        };
        let depth = state.camera.z.abs().max(1.0) as f64;
        state = stage.solve(1e-4 * depth).0;
    }
    (
        SourceView {
            pose: state.pose,
            camera: camera_for(state.camera, side),
            crop: view.crop,
        },
        silhouette,
    )
}

/// The pixels of `inside` with a 4-neighbour outside it, within the image (the photo's edge is no
/// outline).
fn outline(inside: &[bool], size: usize) -> Vec<bool> {
    (0..size * size)
        .map(|i| {
            let (x, y) = (i % size, i / size);
            inside[i]
                && [
                    (x > 0).then(|| i - 1),
                    (x + 1 < size).then(|| i + 1),
                    (y > 0).then(|| i - size),
                    (y + 1 < size).then(|| i + size),
                ]
                .into_iter()
                .flatten()
                .any(|j| !inside[j])
        })
        .collect()
}
