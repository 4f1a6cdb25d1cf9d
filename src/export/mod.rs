//! Files other tools open: the avatar as a rigged, animated glTF with its splats
//! ([`rigged`]), written through a small binary-glTF builder ([`glb`]).

pub mod glb;
pub mod rigged;

pub use rigged::{ExportError, Exported, export};
