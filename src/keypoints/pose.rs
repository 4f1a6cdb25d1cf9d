//! 2D body keypoints and a person mask from MediaPipe's pose landmark model (`pose_landmark_full`).
//!
//! The model sees a crop of the photo at 256² (RGB in [0, 1], NHWC, as MediaPipe feeds it): the
//! whole photo, or the crop the pose detector places around the person ([`super::PoseDetector`];
//! `Landmarkers::pose` runs both and keeps the answer that sees more of the body). It returns 39
//! landmarks (33 body points and 6 auxiliary) in input pixels with visibility and presence
//! logits, a pose presence score and 256² segmentation logits, all in the crop's frame.

use std::path::Path;

use glam::Vec2;

use super::model::SquareModel;
use super::{Keypoint, Roi, sigmoid};
use crate::body::COCO_KEYPOINTS;
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::SourceImage;
use crate::photo::bilinear_clamped;

/// The converted model shipped in the repository.
pub const POSE_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/pose_landmark_full.onnx"
);
/// The model's input side.
pub const POSE_INPUT: usize = 256;
const LANDMARKS: usize = 39;
/// The body landmarks among them (the rest are auxiliary).
const BODY_LANDMARKS: usize = 33;

/// The COCO body keypoints ([`COCO_KEYPOINTS`], the body's landmark names) with their MediaPipe
/// index.
pub const COCO_FROM_MEDIAPIPE: [(&str, usize); 17] = {
    const INDEX: [usize; 17] = [
        0, 2, 5, 7, 8, 11, 12, 13, 14, 15, 16, 23, 24, 25, 26, 27, 28,
    ];
    let mut out = [("", 0); 17];
    let mut k = 0;
    while k < 17 {
        out[k] = (COCO_KEYPOINTS[k], INDEX[k]);
        k += 1;
    }
    out
};

#[derive(Clone, Debug, PartialEq)]
pub struct PoseKeypoints {
    /// The model's pose presence score in [0, 1].
    pub presence: f32,
    /// The raw landmark rows (x, y, z in input pixels, visibility and presence logits).
    pub landmarks: Vec<[f32; 5]>,
    /// Each landmark's x, y refined by the model's heatmap, as MediaPipe refines them
    /// ([`refine_from_heatmap`]), in input pixels.
    pub refined: Vec<Vec2>,
    /// The crop the model saw.
    pub roi: Roi,
    /// The COCO body points the fit uses: MediaPipe's ([`COCO_FROM_MEDIAPIPE`]), or DWPose's
    /// when EHM-Tracker's models are loaded ([`super::Landmarkers::detect`]).
    pub keypoints: Vec<Keypoint>,
    /// Person probability per pixel of the 256² input, row-major.
    pub mask: Vec<f32>,
    /// How many people the pose detector found on the photo (0 where it did not run); with
    /// more than one these are the points of the one nearest its centre.
    pub people: usize,
}

impl PoseKeypoints {
    /// MediaPipe landmark `i` in source pixels, with its confidence.
    pub fn point(&self, i: usize) -> (Vec2, f32) {
        let l = self.landmarks[i];
        (
            self.roi.to_image(self.refined[i], POSE_INPUT),
            sigmoid(l[3]) * sigmoid(l[4]),
        )
    }

    /// The crop the next frame of a video is seen in: placed by the model's auxiliary
    /// alignment landmarks (33, mid-hip; 34, size and turn) as the detector's crop is, so that
    /// the detector runs only when the person is lost (MediaPipe's pose tracking).
    pub fn next_roi(&self) -> Roi {
        Roi::person(self.point(33).0, self.point(34).0)
    }

    /// How much of the body the model sees: the sum of its 33 body landmarks' confidences.
    pub fn seen(&self) -> f32 {
        (0..BODY_LANDMARKS).map(|i| self.point(i).1).sum()
    }

    /// The mask (bilinear) over a `side`² source image; outside the crop nobody.
    pub fn mask_at(&self, side: usize) -> Vec<f32> {
        (0..side * side)
            .map(|i| self.mask_value(Vec2::new((i % side) as f32 + 0.5, (i / side) as f32 + 0.5)))
            .collect()
    }

    /// The mask (bilinear) at one point of the source image; outside the crop nobody.
    pub fn mask_value(&self, pixel: Vec2) -> f32 {
        if !self.roi.covers(pixel) {
            return 0.0;
        }
        let p = self.roi.to_input(pixel, POSE_INPUT);
        bilinear_clamped(POSE_INPUT, p.x - 0.5, p.y - 0.5, |k| self.mask[k])
    }
}

pub struct PoseLandmarker {
    model: SquareModel,
}

impl PoseLandmarker {
    /// The shipped model on `runtime`.
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(POSE_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        let what = "MediaPipe's pose landmark model";
        Ok(Self {
            model: SquareModel::load(runtime, path, what, 5, POSE_INPUT)?,
        })
    }

    /// Runs the model on `roi` of a source image (its RGB as loaded, before any mask is
    /// applied), or on the whole image without one; keypoints come in the source's pixels.
    pub fn detect(
        &mut self,
        source: &SourceImage,
        roi: Option<Roi>,
    ) -> Result<PoseKeypoints, OnnxError> {
        let roi = roi.unwrap_or(Roi::whole(source.size as f32));
        self.run(&roi.sample(source, POSE_INPUT), roi)
    }

    /// Runs the model on a 256² RGB input in [0, 1] (row-major, interleaved) that shows `roi`
    /// of a source image; keypoints come in the source's pixels.
    pub fn run(&mut self, input: &[f32], roi: Roi) -> Result<PoseKeypoints, OnnxError> {
        let outputs = self.model.run(input)?;
        let raw = self.model.output(&outputs, LANDMARKS * 5, "landmark")?;
        let presence = self.model.output(&outputs, 1, "presence")?[0];
        let mask = self
            .model
            .output(&outputs, POSE_INPUT * POSE_INPUT, "segmentation")?;
        let heatmap = self
            .model
            .output(&outputs, HEATMAP * HEATMAP * LANDMARKS, "heatmap")?;
        let landmarks: Vec<[f32; 5]> = raw
            .chunks_exact(5)
            .map(|c| [c[0], c[1], c[2], c[3], c[4]])
            .collect();
        let mut found = PoseKeypoints {
            presence,
            refined: refine_from_heatmap(&landmarks, heatmap),
            landmarks,
            roi,
            keypoints: Vec::new(),
            mask: mask.iter().map(|&x| sigmoid(x)).collect(),
            people: 0,
        };
        found.keypoints = COCO_FROM_MEDIAPIPE
            .iter()
            .map(|&(name, i)| {
                let (pixel, confidence) = found.point(i);
                Keypoint {
                    name,
                    pixel,
                    confidence,
                }
            })
            .collect();
        Ok(found)
    }
}

/// The heatmap's side (64², one channel per landmark, HWC, logits).
const HEATMAP: usize = 64;
/// MediaPipe's refinement window and the heatmap confidence it needs.
const HEATMAP_KERNEL: usize = 7;
const MIN_HEATMAP_CONFIDENCE: f32 = 0.5;

/// Landmark positions refined as MediaPipe's `RefineLandmarksFromHeatmapCalculator` does: the
/// confidence-weighted mean of the heatmap cells in a 7×7 window around the landmark's cell (cell
/// indices, not centres, as there), kept when the window's best confidence reaches 0.5.
fn refine_from_heatmap(landmarks: &[[f32; 5]], heatmap: &[f32]) -> Vec<Vec2> {
    let to_cells = HEATMAP as f32 / POSE_INPUT as f32;
    landmarks
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let at = Vec2::new(l[0], l[1]);
            let centre = (at * to_cells).floor();
            if centre.cmplt(Vec2::ZERO).any() || centre.cmpge(Vec2::splat(HEATMAP as f32)).any() {
                return at;
            }
            let (cx, cy) = (centre.x as usize, centre.y as usize);
            let r = HEATMAP_KERNEL / 2;
            let (mut sum, mut weighted, mut best) = (0.0, Vec2::ZERO, 0.0f32);
            for row in cy.saturating_sub(r)..(cy + r + 1).min(HEATMAP) {
                for col in cx.saturating_sub(r)..(cx + r + 1).min(HEATMAP) {
                    let c = sigmoid(heatmap[(row * HEATMAP + col) * LANDMARKS + k]);
                    sum += c;
                    best = best.max(c);
                    weighted += c * Vec2::new(col as f32, row as f32);
                }
            }
            if best >= MIN_HEATMAP_CONFIDENCE && sum > 0.0 {
                weighted / sum / to_cells
            } else {
                at
            }
        })
        .collect()
}
