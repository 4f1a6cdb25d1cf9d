//! Where faces are, from MediaPipe's face detector (`face_detection_short_range`, BlazeFace): the
//! photo at 128² (RGB in [-1, 1]) in; per anchor a face box, six keypoints (eyes, nose, mouth,
//! ear tragions) and a score out, decoded by [`super::ssd`] and turned into the face landmark
//! model's crop as MediaPipe's `face_detection_front_detection_to_roi` does: the box turned so
//! the eyes are level, 1.5 × its longer side. Used where the pose model places no face crop.

use std::path::Path;

use glam::Vec2;

use super::Roi;
use super::model::SquareModel;
use super::ssd::{Detection, Ssd, SsdLayout};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::reconstruct::SourceImage;

pub const FACE_DETECTOR_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/face_detection_short_range.onnx"
);
pub const FACE_DETECTOR_INPUT: usize = 128;
/// MediaPipe's face detection solution's default confidence.
const MIN_SCORE: f32 = 0.5;
const CROP_SCALE: f32 = 1.5;

pub struct FaceDetector {
    model: SquareModel,
    ssd: Ssd,
}

impl FaceDetector {
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(FACE_DETECTOR_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        let what = "MediaPipe's face detector";
        Ok(Self {
            model: SquareModel::load(runtime, path, what, 2, FACE_DETECTOR_INPUT)?,
            // Four layers of strides 8, 16, 16, 16, two anchors per cell and layer.
            ssd: Ssd::new(SsdLayout {
                input: FACE_DETECTOR_INPUT,
                grids: &[(8, 2), (16, 6)],
                keypoints: 6,
            }),
        })
    }

    /// The raw outputs for a 128² RGB input in [-1, 1]: per anchor the 16 values and the score
    /// logit.
    pub fn run(&mut self, input: &[f32]) -> Result<(Vec<f32>, Vec<f32>), OnnxError> {
        let outputs = self.model.run(input)?;
        let (anchors, values) = (self.ssd.anchors(), self.ssd.values());
        let boxes = self.model.output(&outputs, anchors * values, "box")?;
        let scores = self.model.output(&outputs, anchors, "score")?;
        Ok((boxes.to_vec(), scores.to_vec()))
    }

    /// The most confident face in raw outputs, in [0, 1] of the input.
    pub fn decode(&self, boxes: &[f32], logits: &[f32]) -> Option<Detection> {
        self.ssd.decode(boxes, logits, MIN_SCORE, 1).pop()
    }

    /// The face landmark model's crop around the most confident face on a square source image.
    pub fn detect(&mut self, source: &SourceImage) -> Result<Option<Roi>, OnnxError> {
        let side = source.size as f32;
        let input: Vec<f32> = Roi::whole(side)
            .sample(source, FACE_DETECTOR_INPUT)
            .iter()
            .map(|v| 2.0 * v - 1.0)
            .collect();
        let (boxes, scores) = self.run(&input)?;
        Ok(self.decode(&boxes, &scores).map(|d| {
            let [lo, hi] = d.bounds.map(|b| b * side);
            // The subject's right eye (on the image's left), then the left.
            let across: Vec2 = (d.keypoints[1] - d.keypoints[0]) * side;
            Roi {
                centre: 0.5 * (lo + hi),
                side: CROP_SCALE * (hi - lo).max_element(),
                angle: across.y.atan2(across.x),
            }
        }))
    }
}
