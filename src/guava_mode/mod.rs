//! GUAVA mode: the learned reconstruction, GUAVA's own networks run through ONNX Runtime
//! (exported from the authors' code by `tools/export_guava_onnx.py`).

pub mod models;
pub mod reconstruct;
pub mod sample;

pub use models::{DecodedGaussians, Dims, Encoded, GuavaModels, GuavaModelsError};
pub use reconstruct::{reconstruct_guava, uv_map};
