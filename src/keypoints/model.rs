//! What the landmark models share: one square RGB input (NHWC, values in [0, 1], as MediaPipe's
//! graphs feed them) and a known number of outputs, checked when the model loads.

use std::path::Path;

use crate::onnx::{OnnxError, OnnxRuntime, Session, TensorF32};

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
