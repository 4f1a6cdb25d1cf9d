//! 21 hand points from MediaPipe's hand landmark model (`hand_landmark_full`): a 224² crop with
//! the fingers pointing up (RGB in [0, 1], NHWC) in; the points in input pixels (x, y, relative
//! depth), a hand-presence score, handedness and metric points out. The crop comes from the
//! pose model's wrist and hand points, then from the model's own first answer.

use std::path::Path;

use glam::Vec2;

use super::model::SquareModel;
use super::{PoseKeypoints, Roi};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::SourceImage;

pub const HAND_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/hand_landmark_full.onnx"
);
pub const HAND_INPUT: usize = 224;
/// MediaPipe's hand points, in its order: the wrist, then each finger from its base to its tip.
pub const HAND_POINTS: [&str; 21] = [
    "wrist",
    "thumb_cmc",
    "thumb_mcp",
    "thumb_ip",
    "thumb_tip",
    "index_mcp",
    "index_pip",
    "index_dip",
    "index_tip",
    "middle_mcp",
    "middle_pip",
    "middle_dip",
    "middle_tip",
    "ring_mcp",
    "ring_pip",
    "ring_dip",
    "ring_tip",
    "pinky_mcp",
    "pinky_pip",
    "pinky_dip",
    "pinky_tip",
];
/// Below this presence the crop holds no hand (MediaPipe's tracking threshold).
const MIN_PRESENCE: f32 = 0.5;

/// The subject's left or right.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Left,
    Right,
}

/// A hand found on a photo.
#[derive(Clone, Debug, PartialEq)]
pub struct HandLandmarks {
    /// Which of the subject's hands (from the pose model's wrist the crop was placed by).
    pub side: Side,
    /// The 21 points in the source's pixel-edge coordinates, in [`HAND_POINTS`] order.
    pub points: Vec<Vec2>,
    pub presence: f32,
    /// The crop the points came from.
    pub roi: Roi,
}

pub struct HandLandmarker {
    model: SquareModel,
}

impl HandLandmarker {
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(HAND_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        let what = "MediaPipe's hand landmark model";
        Ok(Self {
            model: SquareModel::load(runtime, path, what, 4, HAND_INPUT)?,
        })
    }

    /// Runs the model on a 224² RGB input in [0, 1]: the points in input pixels and the
    /// presence score.
    pub fn run(&mut self, input: &[f32]) -> Result<(Vec<[f32; 3]>, f32), OnnxError> {
        let outputs = self.model.run(input)?;
        // Two outputs have 63 values and two have 1: the image points and the presence come
        // first in the model's order.
        let points = self
            .model
            .output(&outputs, HAND_POINTS.len() * 3, "landmark")?;
        let presence = self.model.output(&outputs, 1, "presence")?[0];
        let points = points.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        Ok((points, presence))
    }

    /// The subject's `side` hand where the pose model puts it ([`Self::detect_in`]); `None` if
    /// the pose model is unsure of the wrist or no hand is there.
    pub fn detect(
        &mut self,
        source: &SourceImage,
        pose: &PoseKeypoints,
        side: Side,
    ) -> Result<Option<HandLandmarks>, OnnxError> {
        match Roi::hand_from_pose(pose, side) {
            Some(roi) => self.detect_in(source, roi, side),
            None => Ok(None),
        }
    }

    /// The subject's `side` hand in `roi`, refined once by re-cropping around the first answer;
    /// `None` if no hand is there.
    pub fn detect_in(
        &mut self,
        source: &SourceImage,
        roi: Roi,
        side: Side,
    ) -> Result<Option<HandLandmarks>, OnnxError> {
        self.detect_passes(source, roi, side, 2)
    }

    /// The subject's `side` hand in `roi` after `passes` crops (each placed by the last
    /// answer): a video's next frame takes one, in the crop its last frame's hand places.
    pub fn detect_passes(
        &mut self,
        source: &SourceImage,
        roi: Roi,
        side: Side,
        passes: usize,
    ) -> Result<Option<HandLandmarks>, OnnxError> {
        let found = roi.track(
            source,
            HAND_INPUT,
            MIN_PRESENCE,
            passes,
            |x| self.run(x),
            Roi::hand_from_landmarks,
        )?;
        Ok(found.map(|(points, presence, roi)| HandLandmarks {
            side,
            points,
            presence,
            roi,
        }))
    }
}
