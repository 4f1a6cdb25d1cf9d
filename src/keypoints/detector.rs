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
use super::ssd::{Detection, SsdLayout, SsdModel};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::SourceImage;

pub const DETECTOR_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/pose_detection.onnx"
);
pub const DETECTOR_INPUT: usize = 224;
/// MediaPipe's pose solution's default detection confidence: the person made into the avatar
/// or tracked scores this.
pub const MIN_SCORE: f32 = 0.5;
/// Other people are told apart from them at this score (the composite of two portraits in
/// tests/data/photos scores its second person 0.33).
const OTHER_SCORE: f32 = 0.3;
/// The most people looked for on one photo.
const MAX_PEOPLE: usize = 4;

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
    model: SsdModel,
}

impl PoseDetector {
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(DETECTOR_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        // Five layers of strides 8, 16, 32, 32, 32, two anchors per cell and layer.
        let layout = SsdLayout {
            input: DETECTOR_INPUT,
            grids: &[(8, 2), (16, 2), (32, 6)],
            keypoints: 4,
        };
        Ok(Self {
            model: SsdModel::load(runtime, path, "MediaPipe's pose detector", layout, true)?,
        })
    }

    /// The raw outputs for a 224² RGB input in [-1, 1]: per anchor the 12 values and the score
    /// logit.
    pub fn run(&mut self, input: &[f32]) -> Result<(Vec<f32>, Vec<f32>), OnnxError> {
        self.model.run(input)
    }

    /// The most confident person in raw outputs, in [0, 1] of the input.
    pub fn decode(&self, boxes: &[f32], logits: &[f32]) -> Option<Detection> {
        self.model.decode(boxes, logits, MIN_SCORE, 1).pop()
    }

    /// The people on a square source image who score [`MIN_SCORE`], then the others who score
    /// [`OTHER_SCORE`] (up to four in all), most confident first.
    pub fn detect(&mut self, source: &SourceImage) -> Result<Vec<PersonDetection>, OnnxError> {
        Ok(self
            .model
            .detect_tiers(source, &[MIN_SCORE, OTHER_SCORE], MAX_PEOPLE)?
            .into_iter()
            .map(|d| {
                let k = &d.keypoints;
                PersonDetection {
                    score: d.score,
                    keypoints: [k[0], k[1], k[2], k[3]],
                    roi: Roi::person(k[0], k[1]),
                }
            })
            .collect())
    }
}

impl PersonDetection {
    /// Of `people` on a `side`² image who score [`MIN_SCORE`], the one whose shoulders' middle
    /// is nearest its centre: the one a photo of several is of (a group's most confident
    /// detection is often the largest or the sharpest, not the subject).
    pub fn central(people: &[Self], side: f32) -> Option<&Self> {
        let centre = Vec2::splat(0.5 * side);
        people
            .iter()
            .filter(|p| p.score >= MIN_SCORE)
            .min_by(|a, b| {
                let d = |p: &Self| p.keypoints[2].distance_squared(centre);
                d(a).total_cmp(&d(b))
            })
    }
}
