//! Where the person is, from MediaPipe's pose detector (`pose_detection`, BlazePose's SSD): the
//! photo at 224² (RGB in [-1, 1]) in; per anchor a box, four keypoints and a score out. Decoded
//! as MediaPipe's pose graph decodes it (`SsdAnchorsCalculator`, `TensorsToDetectionsCalculator`,
//! weighted non-maximum suppression) and turned into the pose landmark model's crop
//! (`AlignmentPointsRectsCalculator` and `RectTransformationCalculator` of
//! `pose_detection_to_roi`): centred on the mid-hip keypoint, upright along mid-hip → the
//! keypoint that encodes the body's size and turn, 2 × their distance × 1.25 wide. The photo may
//! cut the hips off; the detector places them anyway, outside the photo if need be.

use std::path::Path;

use glam::Vec2;

use super::model::SquareModel;
use super::{Roi, sigmoid};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::reconstruct::SourceImage;

pub const DETECTOR_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/pose_detection.onnx"
);
pub const DETECTOR_INPUT: usize = 224;
pub const ANCHORS: usize = 2254;
/// Box centre and size, then four keypoints (x, y): offsets in input pixels from the anchor.
const VALUES: usize = 12;
/// MediaPipe's pose solution's default detection confidence.
const MIN_SCORE: f32 = 0.5;
/// Boxes overlapping the best one by more than this (IoU) are averaged into it.
const NMS_OVERLAP: f32 = 0.3;
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
    /// Anchor centres in [0, 1] of the input.
    anchors: Vec<Vec2>,
}

impl PoseDetector {
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(DETECTOR_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        let what = "MediaPipe's pose detector";
        Ok(Self {
            model: SquareModel::load(runtime, path, what, 2, DETECTOR_INPUT)?,
            anchors: anchors(),
        })
    }

    /// The raw outputs for a 224² RGB input in [-1, 1]: per anchor the 12 values and the score
    /// logit.
    pub fn run(&mut self, input: &[f32]) -> Result<(Vec<f32>, Vec<f32>), OnnxError> {
        let outputs = self.model.run(input)?;
        let boxes = self.model.output(&outputs, ANCHORS * VALUES, "box")?;
        let scores = self.model.output(&outputs, ANCHORS, "score")?;
        Ok((boxes.to_vec(), scores.to_vec()))
    }

    /// The most confident person on a square source image, `None` if nobody scores 0.5.
    pub fn detect(&mut self, source: &SourceImage) -> Result<Option<PersonDetection>, OnnxError> {
        let side = source.size as f32;
        let whole = Roi {
            centre: Vec2::splat(side / 2.0),
            side,
            angle: 0.0,
        };
        let input: Vec<f32> = whole
            .sample(source, DETECTOR_INPUT)
            .iter()
            .map(|v| 2.0 * v - 1.0)
            .collect();
        let (boxes, scores) = self.run(&input)?;
        Ok(self.decode(&boxes, &scores).map(|(score, k)| {
            let keypoints = k.map(|p| p * side);
            PersonDetection {
                score,
                keypoints,
                roi: Roi::upright(
                    keypoints[0],
                    CROP_SCALE * 2.0 * keypoints[0].distance(keypoints[1]),
                    keypoints[1] - keypoints[0],
                ),
            }
        }))
    }

    /// The best detection, averaged with the boxes that overlap it (weighted by score): its
    /// score and four keypoints in [0, 1] of the input.
    pub fn decode(&self, boxes: &[f32], logits: &[f32]) -> Option<(f32, [Vec2; 4])> {
        let n = DETECTOR_INPUT as f32;
        let decoded = |i: usize| {
            let v = &boxes[i * VALUES..(i + 1) * VALUES];
            let at = |k: usize| self.anchors[i] + Vec2::new(v[k], v[k + 1]) / n;
            let size = Vec2::new(v[2], v[3]) / n;
            let centre = at(0);
            (
                [centre - size / 2.0, centre + size / 2.0],
                [at(4), at(6), at(8), at(10)],
            )
        };
        let score = |i: usize| sigmoid(logits[i].clamp(-100.0, 100.0));
        let best = (0..ANCHORS)
            .filter(|&i| logits[i].is_finite())
            .max_by(|&a, &b| logits[a].total_cmp(&logits[b]))?;
        if score(best) < MIN_SCORE {
            return None;
        }
        let (best_box, _) = decoded(best);
        let (mut weight, mut sum) = (0.0, [Vec2::ZERO; 4]);
        for i in (0..ANCHORS).filter(|&i| logits[i].is_finite() && score(i) >= MIN_SCORE) {
            let (b, k) = decoded(i);
            if iou(b, best_box) > NMS_OVERLAP {
                weight += score(i);
                for (s, p) in sum.iter_mut().zip(k) {
                    *s += score(i) * p;
                }
            }
        }
        Some((score(best), sum.map(|s| s / weight)))
    }
}

/// MediaPipe's SSD anchors for the pose detector: five layers of strides 8, 16, 32, 32, 32 over
/// 224², two anchors per cell and layer (aspect 1 and the interpolated scale), the three
/// stride-32 layers sharing one grid; fixed size, so only the centres matter.
fn anchors() -> Vec<Vec2> {
    let grids: [(usize, usize); 3] = [(8, 2), (16, 2), (32, 6)];
    let mut out = Vec::with_capacity(ANCHORS);
    for (stride, per_cell) in grids {
        let cells = DETECTOR_INPUT.div_ceil(stride);
        for y in 0..cells {
            for x in 0..cells {
                let centre = Vec2::new(
                    (x as f32 + 0.5) / cells as f32,
                    (y as f32 + 0.5) / cells as f32,
                );
                out.extend(std::iter::repeat_n(centre, per_cell));
            }
        }
    }
    out
}

fn iou(a: [Vec2; 2], b: [Vec2; 2]) -> f32 {
    let (lo, hi) = (a[0].max(b[0]), a[1].min(b[1]));
    let inter = (hi - lo).max(Vec2::ZERO);
    let area = |r: [Vec2; 2]| (r[1] - r[0]).max(Vec2::ZERO).element_product();
    let i = inter.element_product();
    let union = area(a) + area(b) - i;
    if union > 0.0 { i / union } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anchors_match_the_models_outputs() {
        let a = anchors();
        assert_eq!(a.len(), ANCHORS);
        // The first cell of the stride-8 grid, twice; the last of the shared stride-32 grid.
        assert_eq!(a[0], Vec2::splat(0.5 / 28.0));
        assert_eq!(a[1], a[0]);
        assert_eq!(a[ANCHORS - 1], Vec2::splat(6.5 / 7.0));
        assert_eq!(a[28 * 28 * 2], Vec2::splat(0.5 / 14.0));
    }
}
