//! Tracking: per-frame body parameters and cameras, from our file format or imported, played back
//! onto a body model.
//!
//! Data flows one way: a file ([`Tracking`], or [`import`] from ARKit CSV / SMPL-X npz) →
//! [`Retarget`] (channel names matched to one model, losses reported) → [`Player`] time →
//! [`Retarget::sample`] into a [`crate::body::BodyPose`] → the body model.

mod format;
pub mod import;
mod playback;
mod retarget;
mod source_view;

pub use format::{
    BodyKind, EhmIdentityRecord, Frame, Identity, MAX_COEFFICIENT, MAX_ROTATION, MAX_TRANSLATION,
    TRACKING_FORMAT, TrackedCamera, Tracking, TrackingError,
};
pub use playback::{Player, camera_at};
pub(crate) use retarget::rig_of;
pub use retarget::{Retarget, RetargetReport};
pub use source_view::SourceView;

/// The shipped demo motion for the default body (`tools/make_demo_motion.py`).
pub const DEMO_MOTION_JSON: &[u8] = include_bytes!("../../assets/demo_motion.json");

/// The embedded demo motion, parsed and validated (the tests check it loads).
pub fn demo_motion() -> Result<Tracking, TrackingError> {
    Tracking::from_json(DEMO_MOTION_JSON, "assets/demo_motion.json (embedded)")
}
