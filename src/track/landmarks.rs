//! MediaPipe's models in tracking mode, as its holistic graph runs them on a video: each model
//! sees the crop its own answer on the last frame places (one pass), and the detectors run only
//! when that answer is lost. A photo's detection ([`Landmarkers::detect`]) runs the detectors
//! and two passes of every landmark model instead.

use std::time::{Duration, Instant};

use crate::keypoints::{
    Detections, HandLandmarks, Landmarkers, PersonDetection, PoseKeypoints, Roi, Side,
};
use crate::onnx::OnnxError;
use crate::photo::SourceImage;

/// Below this pose presence the person is lost and the detector looks for them again
/// (MediaPipe's tracking threshold, as the fit's).
const MIN_POSE_PRESENCE: f32 = crate::fit::MIN_PRESENCE;
/// A search that found nothing better waits this many frames before the next: on a head and
/// shoulders video the pose model's presence hovers about ½ for seconds, and a search each
/// frame (the detector, then the pose model in its crop) tripled the frame's time.
const SEARCH_EVERY: usize = 10;
/// A hand looked for where the pose model puts its wrist and not found there is looked for
/// again after this many frames (hands below the frame were searched on every frame).
const HAND_SEARCH_EVERY: usize = 6;
/// A tracked hand the hand model loses (its presence under ½: a hand over the face, whose
/// fingers move across it) is looked for again where it was, for this many frames (a quarter
/// of a second): in its last crop grown [`LOST_HAND_GROWTH`] times, two passes, as a photo's.
/// The palm detector, which would find it afresh, scores a hand over a face under its
/// threshold: on the shipped clip her hand was gone for 30 frames (88–118), and is now found
/// again in the next frame (1.3 times the crop: within 8 frames, or 3 in the clip's own run).
const LOST_HAND_FRAMES: usize = 6;
const LOST_HAND_GROWTH: f32 = 2.0;

/// What ran on a frame and how long each part took, for `guava track` and its benchmark.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ModelRuns {
    /// The pose detector (the person was lost, or this is the first frame).
    pub person_search: bool,
    /// The face was looked for afresh (from the pose's face points, then the face detector).
    pub face_search: bool,
    /// Hands looked for afresh: again where they were lost, from the pose's wrists, and by the
    /// palm detector.
    pub hand_searches: usize,
    /// Time in the pose, face, hand and iris models (each with its crops' sampling and any
    /// search), in [`MODEL_PARTS`] order.
    pub times: [Duration; 4],
}

/// The parts [`ModelRuns::times`] counts.
pub const MODEL_PARTS: [&str; 4] = ["pose", "face", "hands", "irises"];

/// Where the models look on the next frame.
#[derive(Default)]
pub struct LandmarkTracker {
    /// The pose model's crop: `None` until a person is found; the whole frame when the person
    /// fills it (a portrait, where the detector's full-body crop shrinks them).
    pose_roi: Option<Roi>,
    face_roi: Option<Roi>,
    hand_rois: [Option<Roi>; 2],
    /// Frames since each hand was last found (its crop is kept for [`LOST_HAND_FRAMES`]).
    hand_lost_for: [usize; 2],
    /// Frames since the person, and each hand, were last searched for.
    since_search: usize,
    since_hand_search: [usize; 2],
    /// Frames since the palm detector last looked for a hand the pose model places no wrist for.
    since_palm_search: usize,
}

impl LandmarkTracker {
    /// Forgets every crop: the next frame is searched as a photo is.
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// Starts from a frame detected as a photo is (the first frame of a clip): its answers
    /// place the next frame's crops.
    pub fn seed(&mut self, found: &Detections, source: &SourceImage) {
        // The photo's fit used this pose: its crop is the place to look next.
        self.pose_roi = Some(next_pose_roi(&found.pose, source));
        self.face_roi = found
            .face
            .as_ref()
            .map(|f| Roi::face_from_landmarks(&f.points));
        for (k, side) in [Side::Left, Side::Right].into_iter().enumerate() {
            self.hand_rois[k] = found
                .hands
                .iter()
                .find(|h| h.side == side)
                .map(|h| Roi::hand_from_landmarks(&h.points));
        }
    }

    /// Every model on `source`, in the crops the last frame placed.
    pub fn detect(
        &mut self,
        models: &mut Landmarkers,
        source: &SourceImage,
    ) -> Result<(Detections, ModelRuns), OnnxError> {
        let mut runs = ModelRuns::default();
        // EHM-Tracker's whole-body models have no tracking mode: every frame as a photo.
        if models.wholebody.is_some() {
            let found = models.detect(source)?;
            runs.person_search = true;
            return Ok((found, runs));
        }
        let mut clock = Instant::now();
        let mut lap = |runs: &mut ModelRuns, part: usize| {
            runs.times[part] = clock.elapsed();
            clock = Instant::now();
        };
        let pose = self.pose(models, source, &mut runs)?;
        lap(&mut runs, 0);
        let face = match self.face_roi {
            Some(roi) => models.face.detect_passes(source, roi, 1)?,
            None => None,
        };
        let mut face = match face {
            Some(face) => Some(face),
            None => {
                runs.face_search = true;
                models.face(source, &pose)?
            }
        };
        self.face_roi = face.as_ref().map(|f| Roi::face_from_landmarks(&f.points));
        lap(&mut runs, 1);
        let mut hands: Vec<HandLandmarks> = Vec::new();
        let mut unplaced = false;
        for (k, side) in [Side::Left, Side::Right].into_iter().enumerate() {
            let tracked = match self.hand_rois[k] {
                Some(roi) if self.hand_lost_for[k] > 0 => {
                    runs.hand_searches += 1;
                    let grown = Roi {
                        side: LOST_HAND_GROWTH * roi.side,
                        ..roi
                    };
                    models.hand.detect_in(source, grown, side)?
                }
                Some(roi) => models.hand.detect_passes(source, roi, side, 1)?,
                None => None,
            };
            self.since_hand_search[k] += 1;
            let from_pose = Roi::hand_from_pose(&pose, side);
            unplaced |= tracked.is_none() && from_pose.is_none();
            let search = from_pose.filter(|_| self.since_hand_search[k] >= HAND_SEARCH_EVERY);
            let hand = match (tracked, search) {
                (Some(hand), _) => Some(hand),
                (None, Some(roi)) => {
                    runs.hand_searches += 1;
                    self.since_hand_search[k] = 0;
                    models.hand.detect_in(source, roi, side)?
                }
                (None, None) => None,
            };
            hands.extend(hand);
        }
        // A hand the pose model places no wrist for (a hand over a face close up, where it
        // sees no body) is looked for by the palm detector, as a photo's is.
        self.since_palm_search += 1;
        if unplaced && self.since_palm_search >= HAND_SEARCH_EVERY {
            runs.hand_searches += 1;
            self.since_palm_search = 0;
            models.hands_from_palms(source, &pose, face.as_ref(), &mut hands)?;
        }
        for (k, side) in [Side::Left, Side::Right].into_iter().enumerate() {
            match hands.iter().find(|h| h.side == side) {
                Some(hand) => {
                    self.hand_rois[k] = Some(Roi::hand_from_landmarks(&hand.points));
                    self.hand_lost_for[k] = 0;
                }
                None => {
                    self.hand_lost_for[k] += 1;
                    if self.hand_lost_for[k] > LOST_HAND_FRAMES {
                        self.hand_rois[k] = None;
                    }
                }
            }
        }
        lap(&mut runs, 2);
        let irises = match &mut face {
            Some(face) => models.iris.detect(source, face)?,
            None => Vec::new(),
        };
        lap(&mut runs, 3);
        let found = Detections {
            pose,
            face,
            hands,
            irises,
            person: None,
            segmentation: None,
            others: Vec::new(),
        };
        Ok((found, runs))
    }

    /// The pose model in last frame's crop. Where it loses the person, the detector's crop is
    /// tried (at most every [`SEARCH_EVERY`] frames) and kept if the pose model sees more of the
    /// body there; with no crop yet, the photo's search (the whole frame and the detector's
    /// crop).
    fn pose(
        &mut self,
        models: &mut Landmarkers,
        source: &SourceImage,
        runs: &mut ModelRuns,
    ) -> Result<PoseKeypoints, OnnxError> {
        self.since_search += 1;
        let Some(roi) = self.pose_roi else {
            runs.person_search = true;
            self.since_search = 0;
            let pose = models.pose(source)?;
            self.pose_roi =
                (pose.presence >= MIN_POSE_PRESENCE).then(|| next_pose_roi(&pose, source));
            return Ok(pose);
        };
        let mut pose = models.pose.detect(source, Some(roi))?;
        if pose.presence < MIN_POSE_PRESENCE && self.since_search >= SEARCH_EVERY {
            runs.person_search = true;
            self.since_search = 0;
            let people = models.detector.detect(source)?;
            if let Some(person) = PersonDetection::central(&people, source.size as f32) {
                let cropped = models.pose.detect(source, Some(person.roi))?;
                if cropped.seen() > pose.seen() {
                    pose = cropped;
                }
            }
        }
        // A crop the person left stays until they are found again.
        if pose.presence >= MIN_POSE_PRESENCE {
            self.pose_roi = Some(next_pose_roi(&pose, source));
        }
        Ok(pose)
    }
}

/// Where the pose model looks next: the whole frame again when it saw the person there (the
/// photo path chose it over the detector's crop: the person fills the frame), else the crop its
/// alignment landmarks place.
fn next_pose_roi(pose: &PoseKeypoints, source: &SourceImage) -> Roi {
    let whole = Roi::whole(source.size as f32);
    if pose.roi == whole {
        whole
    } else {
        pose.next_roi()
    }
}
