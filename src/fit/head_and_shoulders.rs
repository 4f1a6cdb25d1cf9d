//! Body keypoints for a photo framed tighter than GUAVA's: a head-and-shoulders portrait, on
//! which the pose model finds no body (the demo portrait's top 360² gets a presence of 0.04)
//! while the face detector, the face mesh and the person segmentation see the person plainly.
//! The head's points come from the face mesh; the shoulders' from the person mask, at the height
//! and inset the body's own proportions give, scaled by the face's eye span (from the proportions
//! alone where the mask has no person there).

use glam::Vec2;

use crate::body::BodyModel;
use crate::keypoints::{FACE_LEFT_EYE, FACE_NOSE, FACE_RIGHT_EYE, FaceLandmarks, Keypoint};

/// Face-mesh points standing for the COCO ears: the face's edge at the ears' height (the nose
/// and eyes are [`FACE_NOSE`] and the midpoints of [`FACE_LEFT_EYE`] and [`FACE_RIGHT_EYE`]).
const LEFT_EAR: usize = 454;
const RIGHT_EAR: usize = 234;
/// Vertices this close to the shoulder points' height (metres) make the body's outline there.
const SHOULDER_BAND_M: f32 = 0.01;

/// Where the body puts its shoulder points, in its eye span, from the eyes' midpoint at rest:
/// how far below, how far apart, and what share of the outline's half-width at that height they
/// sit at.
struct Proportions {
    below: f32,
    half_width: f32,
    inset: f32,
}

impl Proportions {
    fn of(body: &BodyModel) -> Option<Self> {
        let marks = body.landmark_positions(&body.vertices);
        let at = |n: &str| {
            let i = body.landmarks.iter().position(|l| l.name == n)?;
            Some(marks[i])
        };
        let (le, re) = (at("left_eye")?, at("right_eye")?);
        let (ls, rs) = (at("left_shoulder")?, at("right_shoulder")?);
        let span = le.distance(re);
        let (eyes, shoulders) = (0.5 * (le + re), 0.5 * (ls + rs));
        let outline = body
            .vertices
            .iter()
            .filter(|v| (v.y - shoulders.y).abs() < SHOULDER_BAND_M)
            .map(|v| (v.x - shoulders.x).abs())
            .fold(0.0f32, f32::max);
        (span > 0.0 && outline > 0.0).then(|| Self {
            below: (eyes.y - shoulders.y) / span,
            half_width: 0.5 * ls.distance(rs) / span,
            inset: 0.5 * ls.distance(rs) / outline,
        })
    }
}

/// The COCO head and shoulder keypoints of `face` (source pixels of a `side`² image), the
/// shoulders at the height the body's proportions give below the eyes, inside the person
/// mask's outline there (`mask` at a pixel's centre, the person ≥ ½; only that row is read);
/// `None` when the body or the face mesh lacks the points.
pub fn keypoints_from_face(
    body: &BodyModel,
    face: &FaceLandmarks,
    mask: impl Fn(Vec2) -> f32,
    side: u32,
) -> Option<Vec<Keypoint>> {
    let proportions = Proportions::of(body)?;
    let point = |i: usize| face.points.get(i).copied();
    let mid = |[a, b]: [usize; 2]| Some(0.5 * (point(a)? + point(b)?));
    let (left_eye, right_eye) = (mid(FACE_LEFT_EYE)?, mid(FACE_RIGHT_EYE)?);
    let span = left_eye.distance(right_eye);
    let eyes = 0.5 * (left_eye + right_eye);
    // Image y grows downward; the shoulders are below the eyes.
    let y = eyes.y + proportions.below * span;
    let size = side as usize;
    // The mask's row at that height (its last row when the photo ends above it): the shoulders
    // sit inside its run under the face; where the mask has no person there (the pose model's
    // segmentation failed with its points), as far apart as the body's proportions say.
    let row = (y.max(0.0) as usize).min(size - 1);
    let inside = |x: usize| mask(Vec2::new(x as f32 + 0.5, row as f32 + 0.5)) >= 0.5;
    let centre = (eyes.x.max(0.0) as usize).min(size - 1);
    let (middle, half) = if inside(centre) {
        let left_edge = (0..centre).rev().find(|&x| !inside(x)).map_or(0, |x| x + 1);
        let right_edge = (centre..size).find(|&x| !inside(x)).unwrap_or(size);
        (
            0.5 * (left_edge + right_edge) as f32,
            proportions.inset * 0.5 * (right_edge - left_edge) as f32,
        )
    } else {
        (eyes.x, proportions.half_width * span)
    };
    let keypoint = |name, pixel| Keypoint {
        name,
        pixel,
        confidence: 1.0,
    };
    Some(vec![
        keypoint("nose", point(FACE_NOSE)?),
        keypoint("left_eye", left_eye),
        keypoint("right_eye", right_eye),
        keypoint("left_ear", point(LEFT_EAR)?),
        keypoint("right_ear", point(RIGHT_EAR)?),
        // The person's left shoulder is on the image's right.
        keypoint("left_shoulder", Vec2::new(middle + half, y)),
        keypoint("right_shoulder", Vec2::new(middle - half, y)),
    ])
}
