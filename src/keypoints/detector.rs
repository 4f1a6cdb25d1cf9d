//! Where the person is, from MediaPipe's pose detector (`pose_detection`, BlazePose's SSD): the
//! photo at 224² (RGB in [-1, 1]) in; per anchor a box, four keypoints and a score out, decoded
//! by [`super::ssd`] and turned into the pose landmark model's crop as MediaPipe's
//! `pose_detection_to_roi` does (`AlignmentPointsRectsCalculator`, `RectTransformationCalculator`):
//! centred on the mid-hip keypoint, upright along mid-hip → the keypoint that encodes the body's
//! size and turn, 2 × their distance × 1.25 wide. The photo may cut the hips off; the detector
//! places them anyway, outside the photo if need be.

use std::path::Path;

use glam::Vec2;

use super::Roi;
use super::model::SquareModel;
use super::ssd::{Detection, Ssd, SsdLayout};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::reconstruct::SourceImage;

pub const DETECTOR_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/pose_detection.onnx"
);
pub const DETECTOR_INPUT: usize = 224;
/// MediaPipe's pose solution's default detection confidence.
const MIN_SCORE: f32 = 0.5;
/// The crop's margin around the detected body (as in training).
const CROP_SCALE: f32 = 1.25;

/// A person found on a photo.
#[derive(Clone, Debug, PartialEq)]
pub struct PersonDetection {
    pub score: f32,
    /// Mid-hip, the full body's size-and-turn point, mid-shoulder, the upper body's: source
    /// pixels.
    pub keypoints: [Vec2; 4],
    /// The pose landmark model's crop.
    pub roi: Roi,
}

pub struct PoseDetector {
    model: SquareModel,
    ssd: Ssd,
}

impl PoseDetector {
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(DETECTOR_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        let what = "MediaPipe's pose detector";
        Ok(Self {
            model: SquareModel::load(runtime, path, what, 2, DETECTOR_INPUT)?,
            // Five layers of strides 8, 16, 32, 32, 32, two anchors per cell and layer.
            ssd: Ssd::new(SsdLayout {
                input: DETECTOR_INPUT,
                grids: &[(8, 2), (16, 2), (32, 6)],
                keypoints: 4,
            }),
        })
    }

    /// The raw outputs for a 224² RGB input in [-1, 1]: per anchor the 12 values and the score
    /// logit.
    pub fn run(&mut self, input: &[f32]) -> Result<(Vec<f32>, Vec<f32>), OnnxError> {
        let outputs = self.model.run(input)?;
        let (anchors, values) = (self.ssd.anchors(), self.ssd.values());
        let boxes = self.model.output(&outputs, anchors * values, "box")?;
        let scores = self.model.output(&outputs, anchors, "score")?;
        Ok((boxes.to_vec(), scores.to_vec()))
    }

    /// The most confident person in raw outputs, in [0, 1] of the input.
    pub fn decode(&self, boxes: &[f32], logits: &[f32]) -> Option<Detection> {
        self.ssd.decode(boxes, logits, MIN_SCORE, 1).pop()
    }

    /// The most confident person on a square source image, `None` if nobody scores 0.5.
    pub fn detect(&mut self, source: &SourceImage) -> Result<Option<PersonDetection>, OnnxError> {
        let side = source.size as f32;
        let input: Vec<f32> = Roi::whole(side)
            .sample(source, DETECTOR_INPUT)
            .iter()
            .map(|v| 2.0 * v - 1.0)
            .collect();
        let (boxes, scores) = self.run(&input)?;
        Ok(self.decode(&boxes, &scores).map(|d| {
            let k = |i: usize| d.keypoints[i] * side;
            let keypoints = [k(0), k(1), k(2), k(3)];
            PersonDetection {
                score: d.score,
                keypoints,
                roi: Roi::upright(
                    keypoints[0],
                    CROP_SCALE * 2.0 * keypoints[0].distance(keypoints[1]),
                    keypoints[1] - keypoints[0],
                ),
            }
        }))
    }
}
