//! Body keypoints for a photo framed tighter than GUAVA's: a head-and-shoulders portrait, on
//! which the pose model finds no body (the demo portrait's top 360² gets a presence of 0.04)
//! while the face detector, the face mesh and the person segmentation see the person plainly.
//! The head's points come from the face mesh; the shoulders' from the person mask, at the height
//! and inset the body's own proportions give, scaled by the face's eye span (from the proportions
//! alone where the mask has no person there).

use glam::Vec2;

use crate::body::BodyModel;
use crate::keypoints::{FaceLandmarks, Keypoint};

/// The chin's face-mesh point.
const CHIN: usize = 152;
/// Pose-model shoulders both this many eye spans above the face mesh's chin are another reading
/// (on a drawn head the pose model put them on the cheeks, about one span above it).
const SHOULDERS_ABOVE_CHIN_EYE_SPANS: f32 = 0.5;
/// A pose-model nose further than this many eye spans from the face mesh's is another reading.
const NOSE_AGREES_EYE_SPANS: f32 = 0.5;

/// Face-mesh points standing for the COCO head points: the nose tip, each eye's two corners
/// (their midpoint is the eye), and the face's edge at the ears' height. The person's left is
/// MediaPipe's left (the image's right).
const NOSE: usize = 1;
const LEFT_EYE: [usize; 2] = [362, 263];
const RIGHT_EYE: [usize; 2] = [33, 133];
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

/// Why the pose model's confident `keypoints` cannot be the person whose face is `face`, if
/// they cannot: its nose is not the face's, or a shoulder is above the chin. On a drawn body
/// framed from the collarbones up it put both shoulders on the cheeks, with a presence of 0.9.
pub fn contradicts(keypoints: &[Keypoint], face: &FaceLandmarks) -> Option<String> {
    let seen = |name: &str| {
        keypoints
            .iter()
            .find(|k| k.name == name && k.confidence >= super::MIN_CONFIDENCE)
            .map(|k| k.pixel)
    };
    let point = |i: usize| face.points.get(i).copied();
    let (nose, chin) = (point(NOSE)?, point(CHIN)?);
    let span = point(LEFT_EYE[1])?.distance(point(RIGHT_EYE[0])?);
    if seen("nose").is_some_and(|n| n.distance(nose) > NOSE_AGREES_EYE_SPANS * span) {
        return Some("the pose model's nose is not the face's".into());
    }
    // Both, and clearly: one raised shoulder, or a head bent down over it (the cameraman,
    // looking into his camera), is a body, not a misreading.
    let shoulders: Vec<Vec2> = ["left_shoulder", "right_shoulder"]
        .into_iter()
        .filter_map(seen)
        .collect();
    (shoulders.len() == 2
        && shoulders
            .iter()
            .all(|s| s.y < chin.y - SHOULDERS_ABOVE_CHIN_EYE_SPANS * span))
    .then(|| "the pose model's shoulders are above the chin".into())
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
    let (left_eye, right_eye) = (mid(LEFT_EYE)?, mid(RIGHT_EYE)?);
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
        keypoint("nose", point(NOSE)?),
        keypoint("left_eye", left_eye),
        keypoint("right_eye", right_eye),
        keypoint("left_ear", point(LEFT_EAR)?),
        keypoint("right_ear", point(RIGHT_EAR)?),
        // The person's left shoulder is on the image's right.
        keypoint("left_shoulder", Vec2::new(middle + half, y)),
        keypoint("right_shoulder", Vec2::new(middle - half, y)),
    ])
}
