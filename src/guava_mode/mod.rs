//! GUAVA mode: the learned reconstruction, GUAVA's own networks run through ONNX Runtime
//! (exported from the authors' code by `tools/export_guava_onnx.py`).

pub mod models;

pub use models::{DecodedGaussians, Dims, Encoded, GuavaModels, GuavaModelsError};
