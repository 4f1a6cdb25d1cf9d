//! Where faces are, from MediaPipe's face detector (`face_detection_short_range`, BlazeFace): the
//! photo at 128² (RGB in [-1, 1]) in; per anchor a face box, six keypoints (eyes, nose, mouth,
//! ear tragions) and a score out, decoded by [`super::ssd`] and turned into the face landmark
//! model's crop as MediaPipe's `face_detection_front_detection_to_roi` does: the box turned so
//! the eyes are level, 1.5 × its longer side. Used where the pose model places no face crop.

use std::path::Path;

use super::Roi;
use super::ssd::{Detection, SsdLayout, SsdModel};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::SourceImage;

pub const FACE_DETECTOR_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/face_detection_short_range.onnx"
);
pub const FACE_DETECTOR_INPUT: usize = 128;
/// MediaPipe's face detection solution's default confidence.
const MIN_SCORE: f32 = 0.5;
const CROP_SCALE: f32 = 1.5;

pub struct FaceDetector {
    model: SsdModel,
}

impl FaceDetector {
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(FACE_DETECTOR_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        // Four layers of strides 8, 16, 16, 16, two anchors per cell and layer.
        let layout = SsdLayout {
            input: FACE_DETECTOR_INPUT,
            grids: &[(8, 2), (16, 6)],
            keypoints: 6,
        };
        Ok(Self {
            model: SsdModel::load(runtime, path, "MediaPipe's face detector", layout, true)?,
        })
    }

    /// The raw outputs for a 128² RGB input in [-1, 1]: per anchor the 16 values and the score
    /// logit.
    pub fn run(&mut self, input: &[f32]) -> Result<(Vec<f32>, Vec<f32>), OnnxError> {
        self.model.run(input)
    }

    /// The most confident face in raw outputs, in [0, 1] of the input.
    pub fn decode(&self, boxes: &[f32], logits: &[f32]) -> Option<Detection> {
        self.model.decode(boxes, logits, MIN_SCORE, 1).pop()
    }

    /// The face landmark model's crop around the most confident face on a square source image.
    pub fn detect(&mut self, source: &SourceImage) -> Result<Option<Roi>, OnnxError> {
        Ok(self.model.detect(source, MIN_SCORE, 1)?.pop().map(|d| {
            let [lo, hi] = d.bounds;
            // The subject's right eye (on the image's left), then the left.
            let across = d.keypoints[1] - d.keypoints[0];
            Roi {
                centre: 0.5 * (lo + hi),
                side: CROP_SCALE * (hi - lo).max_element(),
                angle: across.y.atan2(across.x),
            }
        }))
    }
}
