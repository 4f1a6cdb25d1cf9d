//! antimatter15's `.splat` files (the format of his WebGL viewer, common on the web): no header,
//! 32 bytes per splat, little-endian: position (3 × f32), scale (3 × f32, linear), colour RGBA
//! (4 × u8: the SH DC colour and the opacity, both in \[0, 1\] times 255), rotation (4 × u8, w x y
//! z, each component of the unit quaternion as 128 + 128·q). Rotations decode as (b − 128)/128,
//! as his viewer does, and are normalised.

use super::{CloudFileError, GaussianCloud, unit_quaternion};
use std::path::Path;

/// Bytes per splat.
pub const RECORD: usize = 32;

pub fn read(path: &Path) -> Result<GaussianCloud, CloudFileError> {
    let bytes = std::fs::read(path).map_err(|error| CloudFileError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    decode(&bytes).map_err(|problem| CloudFileError::Format {
        path: path.to_path_buf(),
        problem,
    })
}

/// Decodes a whole `.splat` file's bytes.
pub fn decode(bytes: &[u8]) -> Result<GaussianCloud, String> {
    if !bytes.len().is_multiple_of(RECORD) {
        return Err(format!(
            "{} bytes is not a whole number of {RECORD}-byte splats: truncated or not a .splat file",
            bytes.len()
        ));
    }
    let mut cloud = GaussianCloud::new(3);
    for record in bytes.chunks_exact(RECORD) {
        let f32_at = |k: usize| {
            let at = 4 * k;
            f32::from_le_bytes(record[at..at + 4].try_into().expect("4 bytes"))
        };
        let unit = |b: u8| f32::from(b) / 255.0;
        let q = [28, 29, 30, 31].map(|at| (f32::from(record[at]) - 128.0) / 128.0);
        cloud.push(
            [f32_at(0), f32_at(1), f32_at(2)],
            unit_quaternion(q),
            [f32_at(3), f32_at(4), f32_at(5)],
            unit(record[27]),
            &[unit(record[24]), unit(record[25]), unit(record[26])],
        );
    }
    Ok(cloud)
}
