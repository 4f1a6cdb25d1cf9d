//! The guava-rs viewer: an eframe window whose central viewport is drawn by the splatting pass
//! (or the body mesh view) on egui's own wgpu device.

pub mod app;
pub mod avatar_view;
pub mod body_model;
pub mod body_panel;
pub mod motion;
pub mod orbit;
pub mod viewport;

pub use app::{CameraMode, GuavaApp, Options, View};
pub use avatar_view::FitAction;
