//! Whether the pose model's points are the body of the person whose face the face mesh found:
//! on a face close up the pose model sees no person, or misreads one (on a drawn body framed
//! from the collarbones up it put both shoulders on the cheeks, with a presence of 0.9). The fit
//! then takes the head and shoulders from the face (`fit::body_keypoints`), and a palm's side
//! comes from the face's midline instead of the pose model's arms.

use glam::Vec2;

use super::{FACE_LEFT_EYE, FACE_NOSE, FACE_RIGHT_EYE, FaceLandmarks, Keypoint, PoseKeypoints};

/// Below this pose presence the pose model sees no person (MediaPipe's tracking threshold), and
/// its landmarks, confident-looking or not, are not fitted.
pub const MIN_PRESENCE: f32 = 0.5;
/// Keypoints the model is less sure of are left out.
pub const MIN_CONFIDENCE: f32 = 0.5;
/// The chin's face-mesh point.
const CHIN: usize = 152;
/// Pose-model shoulders both this many eye spans above the face mesh's chin are another reading
/// (on a drawn head the pose model put them on the cheeks, about one span above it).
const SHOULDERS_ABOVE_CHIN_EYE_SPANS: f32 = 0.5;
/// A pose-model nose further than this many eye spans from the face mesh's is another reading.
const NOSE_AGREES_EYE_SPANS: f32 = 0.5;

/// Why the pose model's points are not the body of the person whose face is `face`, if they are
/// not: it sees no person, or its points contradict the face.
pub fn no_body(pose: &PoseKeypoints, face: Option<&FaceLandmarks>) -> Option<String> {
    let presence = pose.presence;
    if presence.is_nan() || presence < MIN_PRESENCE {
        return Some(format!("the pose model's presence is {presence:.2}"));
    }
    face.and_then(|face| contradicts(&pose.keypoints, face))
}

/// Why the pose model's confident `keypoints` cannot be the person whose face is `face`, if
/// they cannot: its nose is not the face's, or a shoulder is above the chin. On a drawn body
/// framed from the collarbones up it put both shoulders on the cheeks, with a presence of 0.9.
fn contradicts(keypoints: &[Keypoint], face: &FaceLandmarks) -> Option<String> {
    let seen = |name: &str| {
        keypoints
            .iter()
            .find(|k| k.name == name && k.confidence >= MIN_CONFIDENCE)
            .map(|k| k.pixel)
    };
    let point = |i: usize| face.points.get(i).copied();
    let (nose, chin) = (point(FACE_NOSE)?, point(CHIN)?);
    let span = point(FACE_LEFT_EYE[1])?.distance(point(FACE_RIGHT_EYE[0])?);
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
