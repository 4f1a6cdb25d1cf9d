//! What the keypoint models share: MediaPipe's take one square RGB input (NHWC, values in [0, 1],
//! as MediaPipe's graphs feed them), EHM-Tracker's one NCHW input of a fixed size; each has a
//! known number of outputs, checked when the model loads.

use std::path::Path;

use crate::onnx::{OnnxError, OnnxRuntime, Session, TensorF32};
use crate::photo::SourceImage;

pub(super) struct SquareModel {
    session: Session,
    side: usize,
}

impl SquareModel {
    /// `what` names the model in errors ("MediaPipe's face landmark model").
    pub fn load(
        runtime: &OnnxRuntime,
        path: &Path,
        what: &str,
        outputs: usize,
        side: usize,
    ) -> Result<Self, OnnxError> {
        let session = runtime.session(path)?;
        if session.input_names().len() != 1 || session.output_names().len() != outputs {
            return Err(OnnxError::Model {
                path: path.to_path_buf(),
                reason: format!(
                    "expected {what} (1 input, {outputs} outputs), found inputs {:?} and outputs {:?}",
                    session.input_names(),
                    session.output_names()
                ),
            });
        }
        Ok(Self { session, side })
    }

    /// The outputs, in the model's order, for a `side`² RGB input (row-major, interleaved).
    pub fn run(&mut self, input: &[f32]) -> Result<Vec<TensorF32>, OnnxError> {
        let n = self.side;
        assert_eq!(input.len(), n * n * 3, "{n}² RGB input");
        let name = self.session.input_names()[0].clone();
        let tensor = TensorF32 {
            shape: vec![1, n, n, 3],
            data: input.to_vec(),
        };
        self.session.run(vec![(&name, tensor)])
    }

    /// The output of `len` values, or an error naming what is missing.
    pub fn output<'o>(
        &self,
        outputs: &'o [TensorF32],
        len: usize,
        what: &str,
    ) -> Result<&'o [f32], OnnxError> {
        outputs
            .iter()
            .find(|o| o.data.len() == len)
            .map(|o| o.data.as_slice())
            .ok_or_else(|| OnnxError::Run {
                path: self.session.path.clone(),
                reason: format!("the model gave no {what} output ({len} values)"),
            })
    }
}

/// A model with one NCHW RGB input of a fixed size (EHM-Tracker's YOLOX and DWPose) and a known
/// number of outputs, checked when it loads.
pub(super) struct NchwModel {
    session: Session,
    pub width: usize,
    pub height: usize,
}

impl NchwModel {
    /// `what` names the model in errors ("EHM-Tracker's person detector (YOLOX)").
    pub fn load(
        runtime: &OnnxRuntime,
        path: &Path,
        what: &str,
        outputs: usize,
    ) -> Result<Self, OnnxError> {
        let session = runtime.session(path)?;
        let inputs = session.input_shapes();
        let fail = |reason: String| OnnxError::Model {
            path: path.to_path_buf(),
            reason: format!("expected {what}: {reason}"),
        };
        if inputs.len() != 1 || session.output_names().len() != outputs {
            return Err(fail(format!(
                "1 input and {outputs} outputs, found inputs {:?} and outputs {:?}",
                session.input_names(),
                session.output_names()
            )));
        }
        let (width, height) = match inputs[0].1[..] {
            [1, 3, h, w] if h > 0 && w > 0 => (w as usize, h as usize),
            ref shape => {
                return Err(fail(format!(
                    "an input of shape [1, 3, height, width] with fixed sizes, found {shape:?}"
                )));
            }
        };
        Ok(Self {
            session,
            width,
            height,
        })
    }

    pub fn path(&self) -> &Path {
        &self.session.path
    }

    /// The outputs, in the model's order, for an input of 3 planes of `height` × `width`.
    pub fn run(&mut self, planes: Vec<f32>) -> Result<Vec<TensorF32>, OnnxError> {
        assert_eq!(planes.len(), 3 * self.width * self.height, "NCHW input");
        let name = self.session.input_names()[0].clone();
        let tensor = TensorF32 {
            shape: vec![1, 3, self.height, self.width],
            data: planes,
        };
        self.session.run(vec![(&name, tensor)])
    }
}

/// A source image as 8-bit RGB, as OpenCV holds a photo: what EHM-Tracker's models are prepared
/// from (the source was made from 8-bit pixels, so this gives them back). Made once per photo.
pub struct Rgb8 {
    pub side: usize,
    /// `rgb[3·i + c]`, row-major.
    pub rgb: Vec<u8>,
}

impl From<&SourceImage> for Rgb8 {
    fn from(source: &SourceImage) -> Self {
        Self {
            side: source.size as usize,
            rgb: source
                .rgb
                .iter()
                .map(|&v| (v * 255.0).round().clamp(0.0, 255.0) as u8)
                .collect(),
        }
    }
}
