//! LPIPS, the perceptual distance of GUAVA's tables, through an ONNX model the user supplies
//! (`tools/export_lpips_onnx.py` makes one from the `lpips` package and torchvision's AlexNet
//! weights, which cannot ship here). The model reads two RGB images in [-1, 1] as [1, 3, H, W]
//! and gives one number; `guava eval --lpips` runs it on the same person's box as PSNR and SSIM.

use std::path::Path;

use crate::onnx::{OnnxError, OnnxRuntime, Session, TensorF32};

/// The smallest side LPIPS's AlexNet takes (its stride-4 11×11 stem and three 3×3 max pools).
pub const MIN_SIDE: usize = 32;

#[derive(Debug, thiserror::Error)]
pub enum LpipsError {
    #[error(transparent)]
    Onnx(#[from] OnnxError),
    #[error("{path}: not an LPIPS model: {problem}")]
    Model { path: String, problem: String },
    #[error(
        "LPIPS needs images of at least {MIN_SIDE}×{MIN_SIDE}; the person's box is {width}×{height}"
    )]
    TooSmall { width: usize, height: usize },
}

pub struct Lpips {
    session: Session,
    inputs: [String; 2],
}

impl Lpips {
    /// Loads `path` and checks it reads two [1, 3, H, W] images and gives one value.
    pub fn load(runtime: &OnnxRuntime, path: &Path) -> Result<Self, LpipsError> {
        let session = runtime.session(path)?;
        let bad = |problem: String| LpipsError::Model {
            path: path.display().to_string(),
            problem,
        };
        if let Some(role) = session.metadata("role").filter(|r| r != "lpips") {
            return Err(bad(format!("its metadata says it is a {role} model")));
        }
        let inputs = session.input_shapes();
        let [(a, a_shape), (b, b_shape)] = &inputs[..] else {
            return Err(bad(format!(
                "it has {} inputs, not two images",
                inputs.len()
            )));
        };
        for (name, shape) in [(a, a_shape), (b, b_shape)] {
            let image =
                shape.len() == 4 && [1, 3].iter().zip(shape).all(|(w, d)| *d == *w || *d < 0);
            if !image {
                return Err(bad(format!("input {name} is {shape:?}, not [1, 3, H, W]")));
            }
        }
        let outputs = session.output_shapes();
        match &outputs[..] {
            [(_, shape)] if shape.iter().all(|d| *d == 1 || *d < 0) => {}
            _ => return Err(bad(format!("its outputs are {outputs:?}, not one value"))),
        }
        Ok(Self {
            inputs: [a.clone(), b.clone()],
            session,
        })
    }

    /// The distance between two interleaved RGB images in [0, 1], `width × height` each.
    pub fn distance(
        &mut self,
        a: &[f32],
        b: &[f32],
        width: usize,
        height: usize,
    ) -> Result<f64, LpipsError> {
        if width < MIN_SIDE || height < MIN_SIDE {
            return Err(LpipsError::TooSmall { width, height });
        }
        let planar = |rgb: &[f32]| TensorF32 {
            shape: vec![1, 3, height, width],
            data: (0..3)
                .flat_map(|c| (0..width * height).map(move |i| rgb[3 * i + c] * 2.0 - 1.0))
                .collect(),
        };
        let [a_name, b_name] = &self.inputs;
        let out = self.session.run(vec![
            (a_name.as_str(), planar(a)),
            (b_name.as_str(), planar(b)),
        ])?;
        Ok(out
            .first()
            .and_then(|t| t.data.first())
            .copied()
            .unwrap_or(f32::NAN) as f64)
    }
}

/// The `bounds` (`[x0, y0, x1, y1)`) of an interleaved RGB image `size` wide, as its own image.
pub fn crop(rgb: &[f32], size: usize, bounds: [usize; 4]) -> Vec<f32> {
    let [x0, y0, x1, y1] = bounds;
    (y0..y1)
        .flat_map(|y| {
            rgb[3 * (y * size + x0)..3 * (y * size + x1)]
                .iter()
                .copied()
        })
        .collect()
}
