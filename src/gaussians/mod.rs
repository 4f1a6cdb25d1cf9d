//! A cloud of 3D Gaussians with C feature channels: what reconstruction produces, rigging moves and
//! the splatting pass draws. Attributes are stored activated (linear scale, opacity in \[0, 1\]).

pub mod ply;
pub mod splat;
pub mod synthetic;

use std::path::{Path, PathBuf};

/// A splat file that could not be read or written, naming the file. The I/O error is part of the
/// message, not a chained source, so `{:#}` does not print it twice.
#[derive(Debug, thiserror::Error)]
pub enum CloudFileError {
    #[error("{path}: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{path}: {problem}")]
    Format { path: PathBuf, problem: String },
}

/// A file's quaternion at unit length, as 3DGS's `get_rotation` normalises on reading; an all-zero
/// one is kept as it is.
fn unit_quaternion(q: [f32; 4]) -> [f32; 4] {
    let norm = q.iter().map(|c| c * c).sum::<f32>().sqrt();
    if norm > 0.0 { q.map(|c| c / norm) } else { q }
}

/// Reads a splat file by its extension: antimatter15's `.splat`, else 3DGS PLY (standard or
/// PlayCanvas's compressed layout).
pub fn read_file(path: &Path) -> Result<GaussianCloud, CloudFileError> {
    let is_splat = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("splat"));
    if is_splat {
        splat::read(path)
    } else {
        ply::read(path)
    }
}

/// How a splat's opacity meets the splatting pass's screen-space low-pass (0.3 px² added to every
/// projected covariance, as 3DGS's rasterizer does).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LowPass {
    /// As 3DGS and GUAVA's rasterizer: the filter widens a splat at its full opacity, which
    /// clouds optimised through that rasterizer (3DGS scenes, GUAVA's decoders) expect.
    #[default]
    Dilated,
    /// Mip-Splatting's 2D filter (gsplat's "antialiased" mode): the opacity is scaled by
    /// √(det Σ / det(Σ + 0.3 I)), so the filter spreads a splat without adding to its mass. For
    /// the default reconstruction, whose discs are placed to cover their own pixels: dilated, a
    /// subject's outline drew 0.75–1 px wider than its photo's on every side.
    Compensated,
}

/// Gaussian-major storage; `features[i * channels + c]` is channel `c` of Gaussian `i`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GaussianCloud {
    pub channels: usize,
    pub positions: Vec<[f32; 3]>,
    /// Quaternions (w, x, y, z), used as given: like the reference rasterizer
    /// (`forward.cu:computeCov3D`), the splatter does not renormalise them.
    pub rotations: Vec<[f32; 4]>,
    /// Standard deviations along the rotated axes (linear, not log).
    pub scales: Vec<[f32; 3]>,
    /// In [0, 1] (sigmoid already applied).
    pub opacities: Vec<f32>,
    pub features: Vec<f32>,
    /// How the splatting pass low-passes these splats.
    pub low_pass: LowPass,
}

/// Fewest and most feature channels the splatting pass supports.
pub const MIN_CHANNELS: usize = 1;
pub const MAX_CHANNELS: usize = 64;

impl GaussianCloud {
    pub fn new(channels: usize) -> Self {
        assert!(
            (MIN_CHANNELS..=MAX_CHANNELS).contains(&channels),
            "channels must be in {MIN_CHANNELS}..={MAX_CHANNELS}, got {channels}"
        );
        Self {
            channels,
            ..Default::default()
        }
    }

    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    pub fn push(
        &mut self,
        position: [f32; 3],
        rotation: [f32; 4],
        scale: [f32; 3],
        opacity: f32,
        features: &[f32],
    ) {
        assert_eq!(
            features.len(),
            self.channels,
            "feature count must equal the cloud's channels"
        );
        self.positions.push(position);
        self.rotations.push(rotation);
        self.scales.push(scale);
        self.opacities.push(opacity);
        self.features.extend_from_slice(features);
    }

    pub fn features_of(&self, i: usize) -> &[f32] {
        &self.features[i * self.channels..(i + 1) * self.channels]
    }

    /// Turns the whole cloud about the origin: centres and orientations (e.g. a y-up avatar
    /// into the y-down axes 3DGS files use).
    pub fn rotate(&mut self, by: glam::Quat) {
        for (p, r) in self.positions.iter_mut().zip(&mut self.rotations) {
            *p = (by * glam::Vec3::from(*p)).to_array();
            let [w, x, y, z] = *r;
            let q = by * glam::Quat::from_xyzw(x, y, z, w);
            *r = [q.w, q.x, q.y, q.z];
        }
    }

    /// Axis-aligned bounds of the finite centres of the Gaussians that show (opacity at least
    /// 1/255: an avatar keeps the parts its photo did not show, transparent, and framing on
    /// them would put the person at the picture's top), for framing a camera; `None` if none
    /// shows.
    pub fn bounds(&self) -> Option<(glam::Vec3, glam::Vec3)> {
        let mut it = self
            .positions
            .iter()
            .zip(&self.opacities)
            .filter(|&(_, &o)| o >= 1.0 / 255.0)
            .map(|(p, _)| glam::Vec3::from(*p))
            .filter(|p| p.is_finite());
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn bounds_frame_what_shows() {
        let mut cloud = GaussianCloud::new(3);
        let (rotation, scale, colour) = ([1.0, 0.0, 0.0, 0.0], [0.01; 3], [0.5; 3]);
        cloud.push([0.0, 0.0, 0.0], rotation, scale, 0.9, &colour);
        cloud.push([1.0, 2.0, 0.5], rotation, scale, 0.9, &colour);
        cloud.push([0.0, -9.0, 0.0], rotation, scale, 0.0, &colour);
        cloud.push([f32::NAN, 0.0, 0.0], rotation, scale, 0.9, &colour);
        assert_eq!(cloud.bounds(), Some((Vec3::ZERO, Vec3::new(1.0, 2.0, 0.5))));
        cloud.opacities[..2].fill(0.0);
        assert_eq!(cloud.bounds(), None);
    }
}
