//! The refiner pass: the splatting pass's feature image turned into the final picture by a small
//! convolutional network, as GUAVA's StyleUNet turns its 32 channels into RGB. The default mode's
//! refiner (`assets/refiner/default_refiner.onnx`, trained by `tools/train_refiner.py` on
//! [`pairs`]) reads RGB, the source-confidence channel and alpha, and gives RGB and alpha
//! (premultiplied, on black), so it can also clean the silhouette. It runs through ONNX Runtime
//! on the CPU: the splat image is read back, refined and composited.

pub mod pairs;

use std::path::{Path, PathBuf};

use crate::onnx::{OnnxError, OnnxRuntime, Session, TensorF32};
use crate::render::SplatImage;

/// The default refiner, shipped in the repository.
pub const DEFAULT_REFINER: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/refiner/default_refiner.onnx"
);

/// The network's input: [1, 5, H, W] — R, G, B, source confidence, alpha.
pub const INPUT: &str = "splat";
/// Its output: [1, 4, H, W] — R, G, B (premultiplied), alpha.
pub const OUTPUT: &str = "refined";
pub const INPUT_CHANNELS: usize = 5;
pub const OUTPUT_CHANNELS: usize = 4;
/// Sides are padded to a multiple of this (the network halves the image twice).
pub const MULTIPLE: u32 = 4;

#[derive(Debug, thiserror::Error)]
pub enum RefineError {
    #[error(transparent)]
    Onnx(#[from] OnnxError),
    #[error("{path}: {problem}")]
    Model { path: PathBuf, problem: String },
    #[error(
        "the refiner reads RGB and the source-confidence channel: this image has {0} channels \
         (GUAVA mode's 32-channel refiner is not exported yet)"
    )]
    Channels(usize),
}

/// A loaded refiner network.
pub struct Refiner {
    session: Session,
    /// What the model file says it is (its `description` metadata), for the UI and reports.
    pub description: String,
}

impl Refiner {
    /// Loads and checks the model at `path`.
    pub fn load(runtime: &OnnxRuntime, path: &Path) -> Result<Self, RefineError> {
        let session = runtime.session(path)?;
        let problem = |problem: String| RefineError::Model {
            path: path.to_path_buf(),
            problem,
        };
        let channels = |shapes: Vec<(String, Vec<i64>)>, name: &str| {
            shapes
                .into_iter()
                .find(|(n, _)| n == name)
                .and_then(|(_, shape)| shape.get(1).copied())
        };
        match channels(session.input_shapes(), INPUT) {
            Some(c) if c == INPUT_CHANNELS as i64 => {}
            other => {
                return Err(problem(format!(
                    "input `{INPUT}` should have {INPUT_CHANNELS} channels, has {other:?}"
                )));
            }
        }
        match channels(session.output_shapes(), OUTPUT) {
            Some(c) if c == OUTPUT_CHANNELS as i64 => {}
            other => {
                return Err(problem(format!(
                    "output `{OUTPUT}` should have {OUTPUT_CHANNELS} channels, has {other:?}"
                )));
            }
        }
        let description = session
            .metadata("description")
            .unwrap_or_else(|| "refiner".into());
        Ok(Self {
            session,
            description,
        })
    }

    /// `image` (rendered on black, at least RGB and confidence) refined: RGB premultiplied and
    /// alpha; its depth is kept.
    pub fn refine(&mut self, image: &SplatImage) -> Result<SplatImage, RefineError> {
        if image.channels < 4 {
            return Err(RefineError::Channels(image.channels));
        }
        let (w, h) = (image.width as usize, image.height as usize);
        let (pw, ph) = (padded(image.width), padded(image.height));
        let mut input = vec![0.0f32; INPUT_CHANNELS * pw * ph];
        let planes = [
            image.plane(0),
            image.plane(1),
            image.plane(2),
            image.plane(3),
            &image.alpha,
        ];
        for (c, plane) in planes.iter().enumerate() {
            for y in 0..h {
                let row = &plane[y * w..(y + 1) * w];
                let at = (c * ph + y) * pw;
                input[at..at + w].copy_from_slice(row);
            }
        }
        let outputs = self.session.run(vec![(
            INPUT,
            TensorF32 {
                shape: vec![1, INPUT_CHANNELS, ph, pw],
                data: input,
            },
        )])?;
        let out = &outputs[0].data;
        let mut refined = SplatImage::new(image.width, image.height, 3);
        for c in 0..OUTPUT_CHANNELS {
            let target = match c {
                3 => &mut refined.alpha[..],
                _ => &mut refined.features[c * w * h..(c + 1) * w * h],
            };
            for y in 0..h {
                let at = (c * ph + y) * pw;
                target[y * w..(y + 1) * w].copy_from_slice(&out[at..at + w]);
            }
        }
        refined.inv_depth.clone_from(&image.inv_depth);
        Ok(refined)
    }
}

fn padded(side: u32) -> usize {
    side.div_ceil(MULTIPLE) as usize * MULTIPLE as usize
}
