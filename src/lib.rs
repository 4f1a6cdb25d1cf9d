//! guava-rs: GUAVA upper-body Gaussian avatars (ICCV 2025) in Rust on wgpu.
//!
//! Data flows one way: inputs → body → Gaussians → splat → refine → screen. This crate holds
//! every stage, each runnable headless; the `cli` crate is the `guava` command around it, the
//! `ui` crate the viewer window.

pub mod atomic_file;
pub mod avatar;
pub mod body;
pub mod camera;
pub mod eval;
pub mod export;
pub mod fit;
pub mod gaussians;
pub mod gpu;
pub mod guava_mode;
pub mod keypoints;
pub mod npz;
pub mod onnx;
pub mod onnx_model;
pub mod photo;
pub mod pipeline;
pub mod progress;
pub mod raster;
pub mod reconstruct;
pub mod refine;
pub mod render;
pub mod synthetic;
pub mod track;
pub mod tracking;
pub mod video;
pub mod view;

/// The repository the library was built from: its assets (models, the demo portrait, the demo
/// clip) ship in it and are read from there, never downloaded.
pub const REPO: &str = env!("CARGO_MANIFEST_DIR");

/// The demo portrait (the viewer's first launch, benchmarks, tests).
pub const DEMO_PORTRAIT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo_portrait.png");
