//! 2D body keypoints and a person mask from MediaPipe's pose landmark model (`pose_landmark_full`).
//!
//! The model sees the photo's centred square crop at 256² (RGB in [0, 1], NHWC, as MediaPipe
//! feeds it) and returns 39 landmarks (33 body points and 6 auxiliary) in input pixels with
//! visibility and presence logits, a pose presence score and 256² segmentation logits. No pose
//! detector runs first: the crop is the whole centred square, which suits an upper-body portrait
//! that fills the frame (MediaPipe's own pipeline crops around a detected person).

use std::path::Path;

use glam::Vec2;

use super::model::SquareModel;
use super::{Keypoint, sigmoid};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::reconstruct::SourceImage;
use crate::reconstruct::fill::bilinear_clamped;

/// The converted model shipped in the repository.
pub const POSE_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/pose_landmark_full.onnx"
);
/// The model's input side.
pub const POSE_INPUT: usize = 256;
const LANDMARKS: usize = 39;

/// The COCO body keypoints by the default body's landmark names, with their MediaPipe index.
pub const COCO_FROM_MEDIAPIPE: [(&str, usize); 17] = [
    ("nose", 0),
    ("left_eye", 2),
    ("right_eye", 5),
    ("left_ear", 7),
    ("right_ear", 8),
    ("left_shoulder", 11),
    ("right_shoulder", 12),
    ("left_elbow", 13),
    ("right_elbow", 14),
    ("left_wrist", 15),
    ("right_wrist", 16),
    ("left_hip", 23),
    ("right_hip", 24),
    ("left_knee", 25),
    ("right_knee", 26),
    ("left_ankle", 27),
    ("right_ankle", 28),
];

#[derive(Clone, Debug, PartialEq)]
pub struct PoseKeypoints {
    /// The model's pose presence score in [0, 1].
    pub presence: f32,
    /// The raw landmark rows (x, y, z in input pixels, visibility and presence logits).
    pub landmarks: Vec<[f32; 5]>,
    /// Source pixels per input pixel.
    pub scale: f32,
    pub keypoints: Vec<Keypoint>,
    /// Person probability per pixel of the 256² input, row-major.
    pub mask: Vec<f32>,
}

impl PoseKeypoints {
    /// MediaPipe landmark `i` in source pixels, with its confidence.
    pub fn point(&self, i: usize) -> (Vec2, f32) {
        let l = self.landmarks[i];
        (
            Vec2::new(l[0], l[1]) * self.scale,
            sigmoid(l[3]) * sigmoid(l[4]),
        )
    }

    /// The mask resized (bilinear) to `side`² for a source image of that size.
    pub fn mask_at(&self, side: usize) -> Vec<f32> {
        let scale = POSE_INPUT as f32 / side as f32;
        let centre = |i: usize| (i as f32 + 0.5) * scale - 0.5;
        (0..side * side)
            .map(|i| {
                let (x, y) = (centre(i % side), centre(i / side));
                bilinear_clamped(POSE_INPUT, x, y, |k| self.mask[k])
            })
            .collect()
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

    /// Runs the model on a source image (its RGB as loaded, before any mask is applied);
    /// keypoints come in the source's pixels.
    pub fn detect(&mut self, source: &SourceImage) -> Result<PoseKeypoints, OnnxError> {
        let input = downsample_to_input(&source.rgb, source.size as usize);
        self.run(&input, source.size as f32)
    }

    /// Runs the model on a 256² RGB input in [0, 1] (row-major, interleaved); keypoints are
    /// scaled to an image of side `side` that shows the same square.
    pub fn run(&mut self, input: &[f32], side: f32) -> Result<PoseKeypoints, OnnxError> {
        let outputs = self.model.run(input)?;
        let raw = self.model.output(&outputs, LANDMARKS * 5, "landmark")?;
        let presence = self.model.output(&outputs, 1, "presence")?[0];
        let mask = self
            .model
            .output(&outputs, POSE_INPUT * POSE_INPUT, "segmentation")?;
        let landmarks: Vec<[f32; 5]> = raw
            .chunks_exact(5)
            .map(|c| [c[0], c[1], c[2], c[3], c[4]])
            .collect();
        let mut found = PoseKeypoints {
            presence,
            landmarks,
            scale: side / POSE_INPUT as f32,
            keypoints: Vec::new(),
            mask: mask.iter().map(|&x| sigmoid(x)).collect(),
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

/// A `side`² RGB image in [0, 1] (interleaved) as the model's 256² input: box-filtered when
/// `side` is a multiple of 256 (the source images are 512²), else sampled bilinearly at the input
/// pixels' centres (another side, such as GUAVA's 518², works, a little less smoothly).
fn downsample_to_input(rgb: &[f32], side: usize) -> Vec<f32> {
    let k = side / POSE_INPUT;
    if k == 0 || k * POSE_INPUT != side {
        let scale = side as f32 / POSE_INPUT as f32;
        let centre = |i: usize| (i as f32 + 0.5) * scale - 0.5;
        return (0..POSE_INPUT * POSE_INPUT * 3)
            .map(|i| {
                let (p, c) = (i / 3, i % 3);
                let (x, y) = (centre(p % POSE_INPUT), centre(p / POSE_INPUT));
                bilinear_clamped(side, x, y, |q| rgb[q * 3 + c])
            })
            .collect();
    }
    let mut out = vec![0.0; POSE_INPUT * POSE_INPUT * 3];
    let norm = 1.0 / (k * k) as f32;
    for y in 0..side {
        for x in 0..side {
            let o = ((y / k) * POSE_INPUT + x / k) * 3;
            let i = (y * side + x) * 3;
            for c in 0..3 {
                out[o + c] += rgb[i + c] * norm;
            }
        }
    }
    out
}
