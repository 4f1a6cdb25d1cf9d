//! The integration tests, one module per area, in one test binary: each binary links the whole
//! library with wgpu and ONNX Runtime, so one link instead of fifteen keeps CI's build short.
//! `playback_memory` counts heap bytes with its own global allocator and stays a binary of its own.

mod common;
mod npz_writer;

mod body;
mod ehm;
mod ehm_fit;
mod everyday_photos;
mod export_gltf;
mod faults;
mod fidelity;
mod fit;
mod framing;
mod fuzz;
mod guava_mode;
mod guava_models;
mod lpips;
mod mesh_view;
mod onnx_runtime;
mod ply;
mod reconstruct;
mod refiner;
mod splat_stability;
mod splat_vs_reference;
mod tracking;
mod tracking_convert;
mod video_track;
mod view_refine;
mod wholebody;
