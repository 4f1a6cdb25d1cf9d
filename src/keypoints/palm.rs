//! Where hands are, from MediaPipe's palm detector (`palm_detection_full`): the photo at 192²
//! (RGB in [0, 1]) in; per anchor a palm box, seven keypoints (wrist, knuckles, thumb) and a score
//! out, decoded by [`super::ssd`] and turned into the hand landmark model's crop as MediaPipe's
//! `palm_detection_detection_to_roi` does: the box turned so wrist → middle knuckle points up,
//! moved half its height towards the fingers, 2.6 × its longer side.

use std::path::Path;

use glam::Vec2;

use super::Roi;
use super::ssd::{Detection, SsdLayout, SsdModel};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::SourceImage;

pub const PALM_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/palm_detection_full.onnx"
);
pub const PALM_INPUT: usize = 192;
/// MediaPipe's hand solution's default detection confidence.
const MIN_SCORE: f32 = 0.5;
/// Two hands at most, as the viewer fits one person.
const MAX_PALMS: usize = 2;
const CROP_SCALE: f32 = 2.6;
const CROP_SHIFT_TO_FINGERS: f32 = 0.5;

/// A palm found on a photo.
#[derive(Clone, Debug, PartialEq)]
pub struct PalmDetection {
    pub score: f32,
    /// The wrist and the middle finger's knuckle, in source pixels.
    pub wrist: Vec2,
    pub knuckle: Vec2,
    /// The hand landmark model's crop.
    pub roi: Roi,
}

pub struct PalmDetector {
    model: SsdModel,
}

impl PalmDetector {
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(PALM_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        // Four layers of strides 8, 16, 16, 16, two anchors per cell and layer.
        let layout = SsdLayout {
            input: PALM_INPUT,
            grids: &[(8, 2), (16, 6)],
            keypoints: 7,
        };
        Ok(Self {
            model: SsdModel::load(runtime, path, "MediaPipe's palm detector", layout, false)?,
        })
    }

    /// The raw outputs for a 192² RGB input in [0, 1]: per anchor the 18 values and the score
    /// logit.
    pub fn run(&mut self, input: &[f32]) -> Result<(Vec<f32>, Vec<f32>), OnnxError> {
        self.model.run(input)
    }

    /// The palms in raw outputs, best first, in [0, 1] of the input.
    pub fn decode(&self, boxes: &[f32], logits: &[f32]) -> Vec<Detection> {
        self.model.decode(boxes, logits, MIN_SCORE, MAX_PALMS)
    }

    /// The palms on a square source image, best first.
    pub fn detect(&mut self, source: &SourceImage) -> Result<Vec<PalmDetection>, OnnxError> {
        Ok(self
            .model
            .detect(source, MIN_SCORE, MAX_PALMS)?
            .into_iter()
            .map(|d| {
                let [lo, hi] = d.bounds;
                let (wrist, knuckle) = (d.keypoints[0], d.keypoints[2]);
                let size = hi - lo;
                let upright = Roi::upright(0.5 * (lo + hi), 1.0, knuckle - wrist);
                // Half the box's height along the crop's up, which is −y in the crop's frame.
                let up = Vec2::from_angle(upright.angle).rotate(Vec2::NEG_Y);
                PalmDetection {
                    score: d.score,
                    wrist,
                    knuckle,
                    roi: Roi {
                        centre: upright.centre + CROP_SHIFT_TO_FINGERS * size.y * up,
                        side: CROP_SCALE * size.max_element(),
                        angle: upright.angle,
                    },
                }
            })
            .collect())
    }
}
