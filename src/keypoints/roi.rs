//! The square, possibly rotated region of a photo that a landmark model sees, placed as
//! MediaPipe places it: from another model's points, rotated so the feature is upright, with a
//! margin around it.

use glam::{Vec2, Vec3};

use super::{FACE_EYE_CORNERS, Keypoint, PoseKeypoints, Side};
use crate::onnx::OnnxError;
use crate::photo::SourceImage;

/// MediaPipe's margin around a face: the crop is 1.5× the face's longer side.
const FACE_MARGIN: f32 = 1.5;
/// The face mesh spans about 4.5 eye distances with that margin (forehead to chin ≈ 3).
const FACE_SIDE_PER_EYE_DISTANCE: f32 = 4.5;
/// ... and about twice the extent of the pose model's eyes, nose and ears (ear to ear ≈ 2.3 eye
/// distances face on, ear to nose ≈ a face's width in profile).
const FACE_SIDE_PER_EXTENT: f32 = 2.0;
/// Eyes closer than this share of that extent: a head in profile.
const PROFILE_EYE_SHARE: f32 = 0.35;
/// A hand crop spans this many wrist-to-knuckle lengths (the pose model's hand points sit near
/// the knuckles; the fingers reach about as far again).
const HAND_SIDE_PER_PALM: f32 = 4.0;
/// MediaPipe's margin around a hand's points.
const HAND_MARGIN: f32 = 1.6;
/// MediaPipe's pose landmarks of each hand: wrist, pinky, index.
const POSE_HAND: [(Side, [usize; 3]); 2] =
    [(Side::Left, [15, 17, 19]), (Side::Right, [16, 18, 20])];
/// The pose model's crop around the person's alignment points (as in training).
const PERSON_CROP_SCALE: f32 = 1.25;
/// Pose points the face and hand crops need at least this sure.
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

    /// The whole of a `side`² photo.
    pub fn whole(side: f32) -> Self {
        Self {
            centre: Vec2::splat(side / 2.0),
            side,
            angle: 0.0,
        }
    }

    /// Whether a source point lies inside the crop.
    pub fn covers(&self, p: Vec2) -> bool {
        let d = Vec2::from_angle(-self.angle).rotate(p - self.centre);
        d.abs().max_element() <= self.side / 2.0
    }

    /// Where a source point lies in an `n`² model input of this crop (inverse of [`Self::to_image`]).
    pub fn to_input(&self, p: Vec2, n: usize) -> Vec2 {
        let d = Vec2::from_angle(-self.angle).rotate(p - self.centre);
        d * (n as f32 / self.side) + Vec2::splat(n as f32 / 2.0)
    }

    /// The `n`² model input (interleaved RGB, row-major); outside the photo the edge repeats.
    /// Each input pixel is the mean of s × s bilinear samples spread over it, s the source
    /// pixels per input pixel rounded up: one sample when the crop enlarges the photo, a box
    /// filter when it shrinks it (a whole 512² photo at the pose detector's 224², a body crop
    /// several times the photo's side), so that fine detail does not alias. Past
    /// [`MAX_SAMPLES_PER_AXIS`] the photo is first shrunk by a box filter, so that a crop many
    /// times its size (a body crop placed by hips far below a portrait's frame) costs no more
    /// than one four times its size: such a crop took 0.2 s, the pose model 0.01 s.
    pub fn sample(&self, source: &SourceImage, n: usize) -> Vec<f32> {
        let s = (self.side / n as f32).ceil().max(1.0) as usize;
        if s > MAX_SAMPLES_PER_AXIS {
            let factor = s.div_ceil(MAX_SAMPLES_PER_AXIS);
            let small = shrink(source, factor);
            let scale = 1.0 / factor as f32;
            let roi = Self {
                centre: self.centre * scale,
                side: self.side * scale,
                angle: self.angle,
            };
            return roi.sample(&small, n);
        }
        // Input point `at` lies at `origin + at.x · across + at.y · down` in the source's
        // pixel-centre coordinates (`to_image`, minus the half pixel bilinear sampling takes).
        let scale = self.side / n as f32;
        let turn = Vec2::from_angle(self.angle);
        let (across, down) = (turn * scale, turn.perp() * scale);
        let origin = self.centre - (across + down) * (n as f32 / 2.0) - Vec2::splat(0.5);
        let (size, rgb) = (source.size as usize, &source.rgb);
        let max = (size - 1) as f32;
        // Bilinear with the edge repeated, on the interleaved RGB directly (the generic
        // `bilinear_clamped` through a closure took a tenth of a video's tracking time).
        let bilinear = |p: Vec2, c: &mut [f32; 3]| {
            let (x, y) = (p.x.clamp(0.0, max), p.y.clamp(0.0, max));
            let (x0, y0) = (x as usize, y as usize);
            let (x1, y1) = ((x0 + 1).min(size - 1), (y0 + 1).min(size - 1));
            let (fx, fy) = (x - x0 as f32, y - y0 as f32);
            let at = |xi: usize, yi: usize| 3 * (yi * size + xi);
            let (a, b, d, e) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
            let weights = [
                (1.0 - fx) * (1.0 - fy),
                fx * (1.0 - fy),
                (1.0 - fx) * fy,
                fx * fy,
            ];
            for (k, out) in c.iter_mut().enumerate() {
                *out += weights[0] * rgb[a + k]
                    + weights[1] * rgb[b + k]
                    + weights[2] * rgb[d + k]
                    + weights[3] * rgb[e + k];
            }
        };
        let mut out = Vec::with_capacity(n * n * 3);
        let inverse = 1.0 / (s * s) as f32;
        for y in 0..n {
            for x in 0..n {
                let mut c = [0.0f32; 3];
                for j in 0..s {
                    for i in 0..s {
                        let at = Vec2::new(
                            x as f32 + (i as f32 + 0.5) / s as f32,
                            y as f32 + (j as f32 + 0.5) / s as f32,
                        );
                        bilinear(origin + at.x * across + at.y * down, &mut c);
                    }
                }
                out.extend(c.map(|v| v * inverse));
            }
        }
        out
    }

    /// The face crop from the pose model's eyes, nose and ears (`None` if it is unsure of the
    /// eyes and nose): level with the eyes, 4.5 eye distances wide, and at least twice the
    /// extent of those points, so that a head in profile (eyes close together, ear far from
    /// nose) is framed whole; in profile the eye line says little about the head's roll, so the
    /// crop stays upright (the face model's own re-crop levels it).
    pub fn face_from_pose(keypoints: &[Keypoint]) -> Option<Self> {
        let find = |name: &str| {
            keypoints
                .iter()
                .find(|k| k.name == name && k.confidence >= MIN_POSE_CONFIDENCE)
                .map(|k| k.pixel)
        };
        let (left, right, nose) = (find("left_eye")?, find("right_eye")?, find("nose")?);
        let points: Vec<Vec2> = [Some(left), Some(right), Some(nose)]
            .into_iter()
            .chain(["left_ear", "right_ear"].map(find))
            .flatten()
            .collect();
        let (lo, hi) = bounds(points.iter().copied());
        let extent = (hi - lo).max_element();
        // The subject's right eye is on the image's left: right → left runs along +x upright.
        let across = left - right;
        let side =
            (FACE_SIDE_PER_EYE_DISTANCE * across.length()).max(FACE_SIDE_PER_EXTENT * extent);
        if across.length() < PROFILE_EYE_SHARE * extent {
            return Some(Self {
                centre: 0.5 * (lo + hi),
                side,
                angle: 0.0,
            });
        }
        let eyes = 0.5 * (left + right);
        Some(Self {
            centre: eyes + 0.5 * (nose - eyes),
            side,
            angle: across.y.atan2(across.x),
        })
    }

    /// An eye's crop as MediaPipe's iris graph places it: at the midpoint of the eye's corners
    /// `a` and `b` (image-left one first), turned along a → b, `scale` times their longer
    /// extent in the image.
    pub fn eye(a: Vec2, b: Vec2, scale: f32) -> Self {
        let d = b - a;
        Self {
            centre: 0.5 * (a + b),
            side: scale * d.abs().max_element(),
            angle: d.y.atan2(d.x),
        }
    }

    /// The face crop around a face mesh (MediaPipe's landmarks-to-ROI): eye corners level, the
    /// points' bounding box in that frame, its longer side times the margin.
    pub fn face_from_landmarks(points: &[Vec2]) -> Self {
        let across = points[FACE_EYE_CORNERS.1] - points[FACE_EYE_CORNERS.0];
        Self::around(points, across.y.atan2(across.x), FACE_MARGIN)
    }

    /// The crop at `angle` around `points`: their bounding box in that frame, its longer side
    /// times `margin`.
    fn around(points: &[Vec2], angle: f32, margin: f32) -> Self {
        let to_crop = Vec2::from_angle(-angle);
        let (lo, hi) = bounds(points.iter().map(|&p| to_crop.rotate(p)));
        let extent = hi - lo;
        Self {
            centre: Vec2::from_angle(angle).rotate(0.5 * (lo + hi)),
            side: margin * extent.x.max(extent.y),
            angle,
        }
    }

    /// A landmark model's answer in this crop, then, for each further pass, in the crop the
    /// last answer places (as MediaPipe's tracking does between frames: a photo takes 2 passes,
    /// a video's next frame 1 in the crop its last frame placed). `run` maps an `n`² input to
    /// points in input pixels and a presence; below `min_presence` the crop holds nothing and
    /// `None` comes back.
    pub(super) fn track(
        self,
        source: &SourceImage,
        n: usize,
        min_presence: f32,
        passes: usize,
        mut run: impl FnMut(&[f32]) -> Result<(Vec<[f32; 3]>, f32), OnnxError>,
        recrop: fn(&[Vec2]) -> Self,
    ) -> Result<Option<(Vec<Vec2>, f32, Self)>, OnnxError> {
        let mut roi = self;
        let mut found = None;
        for _ in 0..passes.max(1) {
            let (points, presence) = run(&roi.sample(source, n))?;
            if presence < min_presence {
                return Ok(None);
            }
            let points: Vec<Vec2> = points
                .iter()
                .map(|p| roi.to_image(Vec2::new(p[0], p[1]), n))
                .collect();
            let next = recrop(&points);
            found = Some((points, presence, roi));
            roi = next;
        }
        Ok(found)
    }

    /// The `side` hand's crop from the pose model's wrist, pinky and index points, rotated so the
    /// fingers point up (`None` if the pose model is unsure of them).
    pub fn hand_from_pose(pose: &PoseKeypoints, side: Side) -> Option<Self> {
        let (_, [w, p, i]) = POSE_HAND.iter().find(|(s, _)| *s == side)?;
        let [wrist, pinky, index] = [*w, *p, *i].map(|k| pose.point(k));
        if [wrist, pinky, index]
            .iter()
            .any(|(_, c)| *c < MIN_POSE_CONFIDENCE)
        {
            return None;
        }
        let palm = 0.5 * (pinky.0 + index.0) - wrist.0;
        Some(Self::upright(
            wrist.0 + palm,
            HAND_SIDE_PER_PALM * palm.length(),
            palm,
        ))
    }

    /// The crop around a hand's 21 points: wrist to middle knuckle pointing up, the points'
    /// bounding box in that frame, its longer side times the margin.
    pub fn hand_from_landmarks(points: &[Vec2]) -> Self {
        let up = Self::upright(Vec2::ZERO, 1.0, points[9] - points[0]);
        Self::around(points, up.angle, HAND_MARGIN)
    }

    /// The pose landmark model's crop as MediaPipe places it from two alignment points (the pose
    /// detector's, or the pose model's own auxiliary landmarks 33 and 34 on the last frame):
    /// centred on the mid-hip `centre`, upright along centre → `towards` (the point that
    /// encodes the body's size and turn), 2 × their distance × 1.25 wide.
    pub fn person(centre: Vec2, towards: Vec2) -> Self {
        Self::upright(
            centre,
            PERSON_CROP_SCALE * 2.0 * centre.distance(towards),
            towards - centre,
        )
    }

    /// A crop whose up (−y) points along `up` in the image.
    pub fn upright(centre: Vec2, side: f32, up: Vec2) -> Self {
        Self {
            centre,
            side,
            angle: up.x.atan2(-up.y),
        }
    }
}

/// Box-filter samples per input pixel and axis before [`Roi::sample`] shrinks the photo first.
const MAX_SAMPLES_PER_AXIS: usize = 4;

/// `source` shrunk `factor` times by a box filter (its side rounded up; the last row and column
/// average what they cover). The mask is not carried: only the RGB is sampled.
fn shrink(source: &SourceImage, factor: usize) -> SourceImage {
    let size = source.size as usize;
    let small = size.div_ceil(factor);
    let mut rgb = vec![0.0f32; small * small * 3];
    for y in 0..small {
        for x in 0..small {
            let (mut c, mut count) = (Vec3::ZERO, 0.0);
            for sy in y * factor..((y + 1) * factor).min(size) {
                for sx in x * factor..((x + 1) * factor).min(size) {
                    let k = 3 * (sy * size + sx);
                    c += Vec3::from_slice(&source.rgb[k..k + 3]);
                    count += 1.0;
                }
            }
            rgb[3 * (y * small + x)..3 * (y * small + x) + 3]
                .copy_from_slice(&(c / count).to_array());
        }
    }
    SourceImage {
        size: small as u32,
        rgb,
        mask: None,
        shown: crate::photo::Shown::all(small as u32),
    }
}

/// The corners of the axis-aligned box around `points` (infinite, inside out, for none).
pub(super) fn bounds(points: impl IntoIterator<Item = Vec2>) -> (Vec2, Vec2) {
    points.into_iter().fold(
        (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Crops put the feature upright: the model's "up" is wrist → middle knuckle, its "right"
    /// is the eye line, whatever way the hand or face is turned in the photo.
    #[test]
    fn crops_are_upright_for_the_model() {
        let n = 224;
        let top = Vec2::new(n as f32 / 2.0, 0.0);
        for up in [Vec2::X, -Vec2::Y, Vec2::new(-1.0, 1.0).normalize()] {
            let mut points = vec![Vec2::new(100.0, 100.0); 21];
            points[9] = points[0] + 40.0 * up;
            points[12] = points[0] + 80.0 * up;
            let roi = Roi::hand_from_landmarks(&points);
            let towards = (roi.to_image(top, n) - roi.centre).normalize();
            assert!(
                towards.dot(up) > 0.999,
                "{up}: the crop's top is towards {towards}"
            );
            // The points' extent (80 px) times the margin.
            assert!((roi.side - HAND_MARGIN * 80.0).abs() < 1e-3);
        }
        let mut face = vec![Vec2::new(200.0, 200.0); 468];
        face[FACE_EYE_CORNERS.0] = Vec2::new(180.0, 190.0);
        face[FACE_EYE_CORNERS.1] = Vec2::new(220.0, 210.0);
        let roi = Roi::face_from_landmarks(&face);
        let right = (roi.to_image(Vec2::new(192.0, 96.0), 192) - roi.centre).normalize();
        assert!(
            right.dot(Vec2::new(2.0, 1.0).normalize()) > 0.999,
            "{right}"
        );
    }
}
