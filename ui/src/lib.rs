//! The guava-rs viewer: an eframe window whose central viewport is drawn by the library's view
//! renderer (the splatting pass, the rig pass, or the body mesh) on egui's own wgpu device.

pub mod app;
pub mod avatar_view;
pub mod body_model;
pub mod body_panel;
pub mod camera_keys;
pub mod compare;
mod document;
pub mod drive;
mod exports;
mod fidelity;
mod files;
mod ids;
mod jobs;
pub mod motion;
mod offscreen;
pub mod orbit;
mod panels;
pub mod pose_controls;
pub mod recovery;
mod refined;
mod report_plot;
mod settings;
mod shortcuts;
mod viewing;
mod viewport;

pub use app::{GuavaApp, Options};
pub use avatar_view::FitAction;
pub use exports::{CameraPath, Export, ExportSettings};
pub use files::demo_portrait;
pub use panels::demo_video;
pub use viewing::{CameraMode, View};
