//! EHM-Tracker's own keypoint models as it chains them (`wholebody.py`, `DWposeDetector`): YOLOX
//! finds the people, DWPose gives each the 133 COCO-WholeBody points (17 body, 6 feet, 68 face,
//! 21 per hand), and the person whose points span the largest box is kept; with nobody found
//! DWPose sees the whole photo. Loaded from EHM-Tracker's checkpoint folder under its file names
//! ([`WHOLEBODY_FILES`]); the weights are not redistributed here.
//!
//! The fit takes the body and hand points from here and the face, irises and person mask from
//! MediaPipe, as EHM-Tracker weighs the face from MediaPipe's mesh and DWPose's face points
//! barely. EHM-Tracker reorders the body points into OpenPose's 18 (a neck between the
//! shoulders) for its own fit; here they keep COCO's order, which is the fit's.

use std::path::Path;

use glam::Vec2;

use super::hand::{HAND_POINTS, HandLandmarks, Side};
use super::model::Rgb8;
use super::roi::bounds;
use super::simcc::{SimccLandmarker, SimccPoints};
use super::yolox::{PersonBox, PersonDetector};
use super::{COCO_FROM_MEDIAPIPE, Keypoint, Roi, check_folder};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::SourceImage;

/// EHM-Tracker's file names for the person detector and the keypoint model.
pub const WHOLEBODY_FILES: [&str; 2] = ["yolox_l.onnx", "dw-ll_ucoco_384.onnx"];
/// COCO-WholeBody's points: where each hand's 21 start (the subject's left, then right; in
/// MediaPipe's order: wrist, then thumb, index, middle, ring and little finger, base to tip).
const POINTS: usize = 133;
const LEFT_HAND: usize = 91;
const RIGHT_HAND: usize = 112;
/// COCO's body wrists.
const LEFT_WRIST: usize = 9;
const RIGHT_WRIST: usize = 10;
/// DWPose and EHM-Tracker take a point as seen from this score.
const SEEN_SCORE: f32 = 0.3;
/// Two hands whose points lie a mean of less than this many palm lengths apart are one.
const COINCIDENT_PALMS: f32 = 0.5;

pub struct Wholebody {
    person: PersonDetector,
    pose: SimccLandmarker,
}

impl Wholebody {
    /// The two models from EHM-Tracker's checkpoint folder; missing files are named in one error.
    pub fn load_dir(runtime: &OnnxRuntime, dir: &Path) -> Result<Self, OnnxError> {
        check_folder(dir, &WHOLEBODY_FILES, "EHM-Tracker's keypoint model folder")?;
        let [person, pose] = WHOLEBODY_FILES.map(|f| dir.join(f));
        Ok(Self {
            person: PersonDetector::load_from(runtime, &person)?,
            pose: SimccLandmarker::load_from(runtime, &pose)?,
        })
    }

    /// The people YOLOX finds and the points of the one whose points span the largest box (of
    /// the whole photo when it finds nobody).
    pub fn detect(&mut self, source: &SourceImage) -> Result<WholebodyPoints, OnnxError> {
        let photo = Rgb8::from(source);
        let people = self.person.detect(&photo)?;
        let mut best: Option<(f32, SimccPoints, PersonBox)> = None;
        for person in &people {
            let found = self.pose.detect(&photo, Some(person.corners))?;
            let area = spanned_area(&found.points);
            if best.as_ref().is_none_or(|(a, _, _)| area > *a) {
                best = Some((area, found, *person));
            }
        }
        let (found, kept) = match best {
            Some((_, found, person)) => (found, Some(person)),
            None => (self.pose.detect(&photo, None)?, None),
        };
        if found.points.len() != POINTS {
            return Err(OnnxError::Run {
                path: self.pose.path().to_path_buf(),
                reason: format!(
                    "expected COCO-WholeBody's {POINTS} keypoints, found {}",
                    found.points.len()
                ),
            });
        }
        Ok(WholebodyPoints {
            people,
            kept,
            found,
        })
    }
}

/// `DWposeDetector.get_max_area_bbox_index`: the area of the box around all of a person's points.
fn spanned_area(points: &[Vec2]) -> f32 {
    let (lo, hi) = bounds(points.iter().copied());
    let size = hi - lo;
    size.x * size.y
}

/// DWPose's scores are the heights of its SimCC peaks, not probabilities (they pass 1), and it
/// takes a point as seen from 0.3; the fit's keypoint threshold is MediaPipe's 0.5. Scores map
/// linearly on either side of that threshold (0 → 0, 0.3 → 0.5, 1 and more → 1), so the fit uses
/// the points DWPose counts as seen.
pub fn confidence(score: f32) -> f32 {
    let c = if score < SEEN_SCORE {
        0.5 * score / SEEN_SCORE
    } else {
        0.5 + 0.5 * (score - SEEN_SCORE) / (1.0 - SEEN_SCORE)
    };
    if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) }
}

/// What EHM-Tracker's models found on a photo.
#[derive(Clone, Debug, PartialEq)]
pub struct WholebodyPoints {
    /// The people YOLOX found, best first (none: DWPose saw the whole photo).
    pub people: Vec<PersonBox>,
    /// The one whose points were kept (EHM-Tracker's `det_info['bbox']`, the box its tracker
    /// crops the photo around).
    pub kept: Option<PersonBox>,
    /// DWPose's answer for the person kept, in EHM-Tracker's pixel coordinates.
    pub found: SimccPoints,
}

impl WholebodyPoints {
    /// Point `i` in the source's pixel-edge coordinates (EHM-Tracker puts pixel centres at
    /// integers), with its confidence.
    pub fn point(&self, i: usize) -> (Vec2, f32) {
        (
            self.found.points[i] + Vec2::splat(0.5),
            confidence(self.found.scores[i]),
        )
    }

    /// The kept person's box (left, top, right, bottom) in the source's pixel-edge coordinates.
    pub fn person(&self) -> Option<[f32; 4]> {
        self.kept.map(|p| p.corners.map(|c| c + 0.5))
    }

    /// The 17 COCO body points under the fit's names.
    pub fn body(&self) -> Vec<Keypoint> {
        COCO_FROM_MEDIAPIPE
            .iter()
            .enumerate()
            .map(|(i, &(name, _))| {
                let (pixel, confidence) = self.point(i);
                Keypoint {
                    name,
                    pixel,
                    confidence,
                }
            })
            .collect()
    }

    /// Each hand whose 21 points' mean confidence reaches the seen threshold (0.5, a mean score
    /// of about DWPose's 0.3), its presence that mean. DWPose sometimes puts both hands on one
    /// (EHM-Tracker skips such frames): when the two coincide, their points a mean of less than
    /// half a palm apart, only the side whose body wrist is nearer keeps it.
    pub fn hands(&self) -> Vec<HandLandmarks> {
        let hands: Vec<HandLandmarks> = [(Side::Left, LEFT_HAND), (Side::Right, RIGHT_HAND)]
            .into_iter()
            .filter_map(|(side, first)| {
                let (points, confidences): (Vec<Vec2>, Vec<f32>) = (first
                    ..first + HAND_POINTS.len())
                    .map(|i| self.point(i))
                    .unzip();
                let presence = confidences.iter().sum::<f32>() / confidences.len() as f32;
                (presence >= confidence(SEEN_SCORE)).then(|| HandLandmarks {
                    side,
                    roi: Roi::hand_from_landmarks(&points),
                    points,
                    presence,
                })
            })
            .collect();
        let [a, b] = &hands[..] else {
            return hands;
        };
        let apart = a
            .points
            .iter()
            .zip(&b.points)
            .map(|(p, q)| p.distance(*q))
            .sum::<f32>()
            / HAND_POINTS.len() as f32;
        // Wrist to the middle finger's knuckle.
        let palm = |h: &HandLandmarks| h.points[0].distance(h.points[9]);
        if apart >= COINCIDENT_PALMS * 0.5 * (palm(a) + palm(b)) {
            return hands;
        }
        let from_wrist = |h: &HandLandmarks| {
            let wrist = if h.side == Side::Left {
                LEFT_WRIST
            } else {
                RIGHT_WRIST
            };
            h.points[0].distance(self.point(wrist).0)
        };
        let nearer = if from_wrist(a) <= from_wrist(b) { a } else { b };
        vec![nearer.clone()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::keypoints::SimccCrop;

    /// A whole-body answer with both wrists at `wrists`, one hand drawn at `left` and one at
    /// `right` (a palm 10 px long), every point scored 0.9.
    fn answer(wrists: [Vec2; 2], left: Vec2, right: Vec2) -> WholebodyPoints {
        let mut points = vec![Vec2::ZERO; POINTS];
        (points[LEFT_WRIST], points[RIGHT_WRIST]) = (wrists[0], wrists[1]);
        for (first, at) in [(LEFT_HAND, left), (RIGHT_HAND, right)] {
            for k in 0..HAND_POINTS.len() {
                // Fingers fanned upwards from the wrist.
                let (finger, joint) = (k.saturating_sub(1) / 4, (k + 3) % 4 + 1);
                let offset = if k == 0 {
                    Vec2::ZERO
                } else {
                    Vec2::new(finger as f32 * 5.0 - 10.0, -5.0 * joint as f32 - 5.0)
                };
                points[first + k] = at + offset;
            }
        }
        WholebodyPoints {
            people: Vec::new(),
            kept: None,
            found: SimccPoints {
                crop: SimccCrop {
                    centre: glam::DVec2::ZERO,
                    scale: glam::DVec2::ONE,
                },
                points,
                scores: vec![0.9; POINTS],
            },
        }
    }

    #[test]
    fn one_hand_seen_twice_goes_to_the_nearer_wrist() {
        let wrists = [Vec2::new(300.0, 400.0), Vec2::new(100.0, 400.0)];
        // Two hands apart: both kept, each on its side.
        let both = answer(wrists, Vec2::new(300.0, 390.0), Vec2::new(100.0, 390.0)).hands();
        let sides: Vec<Side> = both.iter().map(|h| h.side).collect();
        assert_eq!(sides, vec![Side::Left, Side::Right]);
        // Both on the right wrist, 2 px apart: one hand, the right.
        let one = answer(wrists, Vec2::new(102.0, 390.0), Vec2::new(100.0, 390.0)).hands();
        assert_eq!(one.len(), 1);
        assert_eq!(one[0].side, Side::Right);
        assert_eq!(one[0].points[0], Vec2::new(100.5, 390.5));
    }

    #[test]
    fn dwpose_seen_scores_map_onto_the_fit_threshold() {
        assert_eq!(confidence(0.0), 0.0);
        assert_eq!(confidence(SEEN_SCORE), 0.5);
        assert_eq!(confidence(1.0), 1.0);
        assert_eq!(confidence(1.4), 1.0);
        assert_eq!(confidence(-0.2), 0.0);
        assert_eq!(confidence(f32::NAN), 0.0);
        assert!(confidence(0.29) < 0.5 && confidence(0.31) > 0.5);
    }
}
