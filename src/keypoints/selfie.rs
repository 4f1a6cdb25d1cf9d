//! The person mask from MediaPipe's selfie segmentation model (`selfie_segmentation`, converted
//! with its custom transposed convolution made ONNX's: `tools/convert_mediapipe.py`): the photo's
//! square at 256² (RGB in [0, 1], NHWC) in, each pixel's probability of being a person out. The
//! pose model's own segmentation misses what it was not trained to take for the person on close
//! framings: dark hair against a dark background, a dark uniform (the pose model's mask of the
//! shipped video's close-up covered half the face); this one is trained on such portraits.

use std::path::Path;

use glam::Vec2;

use super::Roi;
use super::model::SquareModel;
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::{SourceImage, bilinear_clamped};

pub const SELFIE_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/selfie_segmentation.onnx"
);
pub const SELFIE_INPUT: usize = 256;

/// A person probability per pixel of a 256² view of the whole source image.
#[derive(Clone, Debug, PartialEq)]
pub struct Segmentation {
    pub mask: Vec<f32>,
}

impl Segmentation {
    /// The mask (bilinear) over a `side`² source image.
    pub fn mask_at(&self, side: usize) -> Vec<f32> {
        let scale = SELFIE_INPUT as f32 / side as f32;
        (0..side * side)
            .map(|i| {
                let p = (Vec2::new((i % side) as f32, (i / side) as f32) + 0.5) * scale;
                bilinear_clamped(SELFIE_INPUT, p.x - 0.5, p.y - 0.5, |k| self.mask[k])
            })
            .collect()
    }
}

pub struct SelfieSegmenter {
    model: SquareModel,
}

impl SelfieSegmenter {
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(SELFIE_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        let what = "MediaPipe's selfie segmentation model";
        Ok(Self {
            model: SquareModel::load(runtime, path, what, 1, SELFIE_INPUT)?,
        })
    }

    /// The person mask of the whole of `source`.
    pub fn segment(&mut self, source: &SourceImage) -> Result<Segmentation, OnnxError> {
        let input = Roi::whole(source.size as f32).sample(source, SELFIE_INPUT);
        let outputs = self.model.run(&input)?;
        let mask = self
            .model
            .output(&outputs, SELFIE_INPUT * SELFIE_INPUT, "segmentation")?
            .to_vec();
        Ok(Segmentation { mask })
    }
}
