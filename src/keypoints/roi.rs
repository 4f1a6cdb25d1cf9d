//! The square, possibly rotated region of a photo that a landmark model sees, placed as
//! MediaPipe places it: from another model's points, rotated so the feature is upright, with a
//! margin around it.

use glam::{Vec2, Vec3};

use super::{FACE_EYE_CORNERS, Keypoint};
use crate::reconstruct::SourceImage;
use crate::reconstruct::fill::bilinear_clamped;

/// MediaPipe's margin around a face: the crop is 1.5× the face's longer side.
const FACE_MARGIN: f32 = 1.5;
/// The face mesh spans about 4.5 eye distances with that margin (forehead to chin ≈ 3).
const FACE_SIDE_PER_EYE_DISTANCE: f32 = 4.5;
/// Pose points the face crop needs at least this sure.
const MIN_POSE_CONFIDENCE: f32 = 0.5;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roi {
    /// Centre in the source's pixel-edge coordinates.
    pub centre: Vec2,
    /// Side in source pixels.
    pub side: f32,
    /// The crop's x axis in the image is (cos, sin) of this (radians; image y points down).
    pub angle: f32,
}

impl Roi {
    /// Where a point of an `n`² model input lies in the source.
    pub fn to_image(&self, p: Vec2, n: usize) -> Vec2 {
        let d = (p - Vec2::splat(n as f32 / 2.0)) * (self.side / n as f32);
        self.centre + Vec2::from_angle(self.angle).rotate(d)
    }

    /// The `n`² model input (interleaved RGB, row-major), sampled bilinearly at each input
    /// pixel's centre; outside the photo the edge repeats.
    pub fn sample(&self, source: &SourceImage, n: usize) -> Vec<f32> {
        let size = source.size as usize;
        let rgb = |k: usize| Vec3::from_slice(&source.rgb[3 * k..3 * k + 3]);
        let mut out = Vec::with_capacity(n * n * 3);
        for y in 0..n {
            for x in 0..n {
                let p = self.to_image(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), n);
                let c = bilinear_clamped(size, p.x - 0.5, p.y - 0.5, rgb);
                out.extend_from_slice(&c.to_array());
            }
        }
        out
    }

    /// The face crop from the pose model's eyes and nose (`None` if it is unsure of them).
    pub fn face_from_pose(keypoints: &[Keypoint]) -> Option<Self> {
        let find = |name: &str| {
            keypoints
                .iter()
                .find(|k| k.name == name && k.confidence >= MIN_POSE_CONFIDENCE)
                .map(|k| k.pixel)
        };
        let (left, right, nose) = (find("left_eye")?, find("right_eye")?, find("nose")?);
        // The subject's right eye is on the image's left: right → left runs along +x upright.
        let across = left - right;
        let eyes = 0.5 * (left + right);
        Some(Self {
            centre: eyes + 0.5 * (nose - eyes),
            side: FACE_SIDE_PER_EYE_DISTANCE * across.length(),
            angle: across.y.atan2(across.x),
        })
    }

    /// The face crop around a face mesh (MediaPipe's landmarks-to-ROI): eye corners level, the
    /// points' bounding box in that frame, its longer side times the margin.
    pub fn face_from_landmarks(points: &[Vec2]) -> Self {
        let across = points[FACE_EYE_CORNERS.1] - points[FACE_EYE_CORNERS.0];
        let angle = across.y.atan2(across.x);
        let to_crop = Vec2::from_angle(-angle);
        let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        for &p in points {
            let q = to_crop.rotate(p);
            lo = lo.min(q);
            hi = hi.max(q);
        }
        let extent = hi - lo;
        Self {
            centre: Vec2::from_angle(angle).rotate(0.5 * (lo + hi)),
            side: FACE_MARGIN * extent.x.max(extent.y),
            angle,
        }
    }
}
