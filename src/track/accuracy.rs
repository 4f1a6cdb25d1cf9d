//! How far a tracked video is from a known answer (a synthetic video's true views): the arms',
//! neck's and head's joints in the picture, as a viewer of the avatar sees them move.

use glam::{Vec2, Vec3};

use crate::body::{BodyModel, PoseError, PosedBody};
use crate::tracking::{SourceView, Tracking, TrackingError};

/// The joints compared.
pub const COMPARED_JOINTS: [&str; 8] = [
    "upperarm01.L",
    "upperarm01.R",
    "lowerarm01.L",
    "lowerarm01.R",
    "wrist.L",
    "wrist.R",
    "neck01",
    "head",
];

#[derive(Debug, thiserror::Error)]
pub enum AccuracyError {
    #[error(transparent)]
    Tracking(#[from] TrackingError),
    #[error(transparent)]
    Pose(#[from] PoseError),
    #[error("the body has no joint {0:?}")]
    Joint(&'static str),
}

/// Per frame, the mean distance in pixels between the [`COMPARED_JOINTS`] where `truth` draws
/// them and where `tracking`'s frame (pose and camera) puts them.
pub fn joint_errors(
    body: &BodyModel,
    truth: &[SourceView],
    tracking: &Tracking,
) -> Result<Vec<f32>, AccuracyError> {
    let at = |view: &SourceView| -> Result<Vec<Vec2>, AccuracyError> {
        let mut posed = PosedBody::default();
        body.pose(&view.pose, &mut posed)?;
        COMPARED_JOINTS
            .iter()
            .map(|&n| {
                let j = body.joint_index(n).ok_or(AccuracyError::Joint(n))?;
                let q = view.camera.project(Vec3::from(posed.joints[j].translation));
                Ok(Vec2::new(q.x, q.y))
            })
            .collect()
    };
    truth
        .iter()
        .enumerate()
        .map(|(i, want)| {
            let got = SourceView::at_frame(tracking, body, i, "the tracking")?;
            let (a, b) = (at(want)?, at(&got)?);
            let sum: f32 = a.iter().zip(&b).map(|(p, q)| p.distance(*q)).sum();
            Ok(sum / COMPARED_JOINTS.len() as f32)
        })
        .collect()
}
