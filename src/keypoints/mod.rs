//! 2D keypoints on a photo from MediaPipe's detectors and landmark models (Apache-2.0, converted
//! to ONNX by `tools/convert_mediapipe.py`) through ONNX Runtime, chained as MediaPipe's holistic
//! pipeline chains them: the pose detector finds the person, the pose model in the crop it places
//! gives the body points and a person mask; the face and hand models see crops placed by the pose
//! model's face and hand points, then second crops placed by their own first answers; the palm
//! and face detectors place crops for hands and faces the pose model missed; the iris model sees
//! each eye of the face mesh. EHM-Tracker's own models (YOLOX and DWPose, [`Wholebody`]) can
//! stand in for the body and hand points.

mod agreement;
mod detector;
mod face;
mod face_detector;
mod hand;
mod iris;
mod model;
mod palm;
mod pose;
mod roi;
mod selfie;
mod simcc;
mod ssd;
mod wholebody;
mod yolox;

pub use agreement::{MIN_CONFIDENCE, MIN_PRESENCE, no_body};
pub use detector::{DETECTOR_INPUT, DETECTOR_MODEL_PATH, PersonDetection, PoseDetector};
pub use face::{
    FACE_EYE_CORNERS, FACE_INPUT, FACE_LEFT_EYE, FACE_MODEL_PATH, FACE_NOSE, FACE_POINTS,
    FACE_RIGHT_EYE, FaceLandmarker, FaceLandmarks,
};
pub use face_detector::{FACE_DETECTOR_INPUT, FACE_DETECTOR_MODEL_PATH, FaceDetector};
pub use hand::{HAND_INPUT, HAND_MODEL_PATH, HAND_POINTS, HandLandmarker, HandLandmarks, Side};
pub use iris::{IRIS_INPUT, IRIS_MODEL_PATH, Iris, IrisLandmarker};
pub use model::Rgb8;
pub use palm::{PALM_INPUT, PALM_MODEL_PATH, PalmDetection, PalmDetector};
pub use pose::{COCO_FROM_MEDIAPIPE, POSE_INPUT, POSE_MODEL_PATH, PoseKeypoints, PoseLandmarker};
pub use roi::Roi;
pub use selfie::{SELFIE_INPUT, SELFIE_MODEL_PATH, Segmentation, SelfieSegmenter};
pub use simcc::{SimccCrop, SimccLandmarker, SimccPoints};
pub use ssd::Detection;
pub use wholebody::{WHOLEBODY_FILES, Wholebody, WholebodyPoints};
pub use yolox::{PersonBox, PersonDetector};

use std::path::Path;

use glam::Vec2;

use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::SourceImage;

/// One error naming every file of `files` that `dir` (`what`) lacks.
fn check_folder(dir: &Path, files: &[&str], what: &str) -> Result<(), OnnxError> {
    let missing: Vec<&str> = files
        .iter()
        .copied()
        .filter(|f| !dir.join(f).is_file())
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    Err(OnnxError::Model {
        path: dir.to_path_buf(),
        reason: format!("{what} lacks {}", missing.join(", ")),
    })
}

/// One keypoint: a named landmark's image position and how sure the model is that it is visible.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keypoint {
    pub name: &'static str,
    /// Pixel-edge coordinates in an image of side `side` (the size `detect` was asked for).
    pub pixel: Vec2,
    /// sigmoid(visibility) · sigmoid(presence), in [0, 1].
    pub confidence: f32,
}

/// Everything the models found on one photo.
#[derive(Clone, Debug, PartialEq)]
pub struct Detections {
    pub pose: PoseKeypoints,
    /// `None` when the pose model saw no face or the face model rejected its crop.
    pub face: Option<FaceLandmarks>,
    /// The hands the hand model found where the pose model put wrists or the palm detector
    /// palms (0, 1 or 2).
    pub hands: Vec<HandLandmarks>,
    /// The irises in the face mesh's eyes (none without a face).
    pub irises: Vec<Iris>,
    /// With EHM-Tracker's models, the box of the person whose points these are (YOLOX's, in
    /// source pixels; [`WholebodyPoints::person`]); `None` with MediaPipe's or when YOLOX
    /// found nobody.
    pub person: Option<[f32; 4]>,
    /// The selfie model's person mask, where it ran (the photo path; a video's later frames
    /// need none).
    pub segmentation: Option<Segmentation>,
    /// The pose model on the other people the detector found (the photo path): their masks
    /// keep them out of this person's.
    pub others: Vec<PoseKeypoints>,
}

impl Detections {
    /// The pose model's answer alone (what masking a photo needs).
    pub fn pose_only(pose: PoseKeypoints) -> Self {
        Self {
            pose,
            face: None,
            hands: Vec::new(),
            irises: Vec::new(),
            person: None,
            segmentation: None,
            others: Vec::new(),
        }
    }

    /// The person's mask over a `side`² source image: the selfie model's where it ran, split
    /// from the other people's by the pose model's masks where they touch (each pixel goes to
    /// whose pose mask is nearer), and only its parts the pose model's person overlaps (another
    /// person beside them is left out); else the pose model's own segmentation; parts too
    /// small to be the person cleared.
    pub fn person_mask(&self, side: usize) -> Vec<f32> {
        let pose = self.pose.mask_at(side);
        let mut mask = match &self.segmentation {
            Some(s) => {
                let mut mask = s.mask_at(side);
                let person: Vec<bool> = pose.iter().map(|&m| m >= 0.5).collect();
                if !self.others.is_empty() {
                    let mut others = vec![false; side * side];
                    for other in &self.others {
                        for (o, m) in others.iter_mut().zip(other.mask_at(side)) {
                            *o |= m >= 0.5;
                        }
                    }
                    crate::photo::keep_nearer(&mut mask, side, &person, &others);
                }
                crate::photo::keep_parts_touching(&mut mask, side, &person);
                mask
            }
            None => pose,
        };
        crate::photo::keep_person(&mut mask, side);
        mask
    }
}

/// Where the shipped models are, and the file names [`Landmarkers::load_dir`] looks for.
pub const MODELS_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/models");
pub const MODEL_FILES: [&str; 8] = [
    "pose_detection.onnx",
    "pose_landmark_full.onnx",
    "face_landmark.onnx",
    "hand_landmark_full.onnx",
    "iris_landmark.onnx",
    "palm_detection_full.onnx",
    "face_detection_short_range.onnx",
    "selfie_segmentation.onnx",
];

/// The keypoint models, loaded once and run on each photo.
pub struct Landmarkers {
    pub detector: PoseDetector,
    pub pose: PoseLandmarker,
    pub face: FaceLandmarker,
    pub hand: HandLandmarker,
    pub iris: IrisLandmarker,
    pub palm: PalmDetector,
    pub face_detector: FaceDetector,
    pub selfie: SelfieSegmenter,
    /// EHM-Tracker's models, when given: they place the body and hand points instead of
    /// MediaPipe's pose and hand models ([`Self::detect`]).
    pub wholebody: Option<Wholebody>,
}

impl Landmarkers {
    /// The shipped models.
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_dir(runtime, Path::new(MODELS_DIR))
    }

    /// Models from a folder, under [`MODEL_FILES`]' names and with the shipped models' inputs
    /// and outputs (a user's own conversions or retrained models). Missing files are listed in
    /// one error; each file is checked for its model's inputs and outputs.
    pub fn load_dir(runtime: &OnnxRuntime, dir: &Path) -> Result<Self, OnnxError> {
        check_folder(dir, &MODEL_FILES, "the keypoint model folder")?;
        let [
            detector,
            pose,
            face,
            hand,
            iris,
            palm,
            face_detector,
            selfie,
        ] = MODEL_FILES.map(|f| dir.join(f));
        Ok(Self {
            detector: PoseDetector::load_from(runtime, &detector)?,
            pose: PoseLandmarker::load_from(runtime, &pose)?,
            face: FaceLandmarker::load_from(runtime, &face)?,
            hand: HandLandmarker::load_from(runtime, &hand)?,
            iris: IrisLandmarker::load_from(runtime, &iris)?,
            palm: PalmDetector::load_from(runtime, &palm)?,
            face_detector: FaceDetector::load_from(runtime, &face_detector)?,
            selfie: SelfieSegmenter::load_from(runtime, &selfie)?,
            wholebody: None,
        })
    }

    /// These models with EHM-Tracker's from its checkpoint folder ([`Wholebody::load_dir`]).
    pub fn with_wholebody(mut self, runtime: &OnnxRuntime, dir: &Path) -> Result<Self, OnnxError> {
        self.wholebody = Some(Wholebody::load_dir(runtime, dir)?);
        Ok(self)
    }

    /// The model that places the body points, for reports.
    pub fn body_points(&self) -> &'static str {
        match self.wholebody {
            Some(_) => "EHM-Tracker's DWPose",
            None => "pose_landmark_full",
        }
    }

    /// Body points and the person mask: the pose model in the crop the pose detector places
    /// (MediaPipe's pipeline) and on the whole photo, keeping the answer that sees more of the
    /// body ([`PoseKeypoints::seen`]). The detector's crop spans the whole body, feet included,
    /// so a person off-centre or in profile is framed as the model was trained, while a portrait
    /// that the person fills shrinks to a corner of it: on the demo portrait the whole photo
    /// gives 11 confident COCO points against the crop's 7, on the cameraman (tests/data) the
    /// crop gives 13 where the whole photo misreads him. With several people on the photo, the
    /// one nearest its centre ([`PersonDetection::central`]), and their count in
    /// [`PoseKeypoints::people`].
    pub fn pose(&mut self, source: &SourceImage) -> Result<PoseKeypoints, OnnxError> {
        Ok(self.people(source, false)?.0)
    }

    /// [`Self::pose`], and with `others` the pose model on each other person the detector
    /// found too.
    fn people(
        &mut self,
        source: &SourceImage,
        others: bool,
    ) -> Result<(PoseKeypoints, Vec<PoseKeypoints>), OnnxError> {
        let people = self.detector.detect(source)?;
        let mut whole = self.pose.detect(source, None)?;
        whole.people = people.len();
        let Some(person) = PersonDetection::central(&people, source.size as f32) else {
            return Ok((whole, Vec::new()));
        };
        let mut cropped = self.pose.detect(source, Some(person.roi))?;
        cropped.people = people.len();
        // With several people the whole photo's pose may be anyone's: the central one's crop
        // decides wherever it sees them at all.
        let several = people.len() > 1 && cropped.seen() > 1.0;
        let pose = match several || cropped.seen() > whole.seen() {
            true => cropped,
            false => whole,
        };
        let mut rest = Vec::new();
        for other in people
            .iter()
            .filter(|p| others && !std::ptr::eq(*p, person))
        {
            rest.push(self.pose.detect(source, Some(other.roi))?);
        }
        Ok((pose, rest))
    }

    /// The pose pipeline on the photo, then the face and hand models where it puts them (and
    /// the hand model where the palm detector finds hands it did not), and the iris model in the
    /// face's eyes. With EHM-Tracker's models loaded, the body's COCO points and the hands are
    /// theirs; the pose model still gives the person's presence and mask, and the face crop
    /// is placed by the body points in use.
    pub fn detect(&mut self, source: &SourceImage) -> Result<Detections, OnnxError> {
        let (mut pose, others) = self.people(source, true)?;
        let mut hands = Vec::new();
        let mut person = None;
        if let Some(wholebody) = &mut self.wholebody {
            let found = wholebody.detect(source)?;
            pose.keypoints = found.body();
            hands = found.hands();
            person = found.person();
        }
        let mut face = self.face(source, &pose)?;
        if self.wholebody.is_none() {
            for side in [Side::Left, Side::Right] {
                hands.extend(self.hand.detect(source, &pose, side)?);
            }
            self.hands_from_palms(source, &pose, face.as_ref(), &mut hands)?;
        }
        let irises = match &mut face {
            Some(face) => self.iris.detect(source, face)?,
            None => Vec::new(),
        };
        let segmentation = Some(self.selfie.segment(source)?);
        Ok(Detections {
            pose,
            face,
            hands,
            irises,
            person,
            segmentation,
            others,
        })
    }

    /// Only what a person mask needs: the pose pipeline's person and the selfie model's mask
    /// ([`Detections::person_mask`]).
    pub fn mask(&mut self, source: &SourceImage) -> Result<Detections, OnnxError> {
        let (pose, others) = self.people(source, true)?;
        let mut found = Detections::pose_only(pose);
        found.segmentation = Some(self.selfie.segment(source)?);
        found.others = others;
        Ok(found)
    }

    /// With EHM-Tracker's models loaded, the box of the person they find on `source`
    /// ([`Detections::person`]); `None` without them or when YOLOX finds nobody.
    pub fn person_box(&mut self, source: &SourceImage) -> Result<Option<[f32; 4]>, OnnxError> {
        match &mut self.wholebody {
            Some(wholebody) => Ok(wholebody.detect(source)?.person()),
            None => Ok(None),
        }
    }

    /// The face mesh in the crop the pose model's face points place, or, when they place none
    /// or the face model finds no face there, in the face detector's crop.
    pub fn face(
        &mut self,
        source: &SourceImage,
        pose: &PoseKeypoints,
    ) -> Result<Option<FaceLandmarks>, OnnxError> {
        if let Some(roi) = Roi::face_from_pose(&pose.keypoints)
            && let Some(face) = self.face.detect(source, roi)?
        {
            return Ok(Some(face));
        }
        match self.face_detector.detect(source)? {
            Some(roi) => self.face.detect(source, roi),
            None => Ok(None),
        }
    }

    /// Hands the pose model did not place (a wrist it was unsure of, a hand far from where it
    /// put it), found from the palm detector: each palm no found hand's crop covers is taken as
    /// the hand of a side that has none yet ([`palm_side`]).
    pub fn hands_from_palms(
        &mut self,
        source: &SourceImage,
        pose: &PoseKeypoints,
        face: Option<&FaceLandmarks>,
        hands: &mut Vec<HandLandmarks>,
    ) -> Result<(), OnnxError> {
        for palm in self.palm.detect(source)? {
            if hands.iter().any(|h| h.roi.covers(palm.knuckle)) {
                continue;
            }
            let free = |s: Side| hands.iter().all(|h| h.side != s);
            if let Some(side) = palm_side(pose, face, palm.wrist, free) {
                hands.extend(self.hand.detect_in(source, palm.roi, side)?);
            }
        }
        Ok(())
    }
}

/// Whose hand a palm with its wrist at `wrist` is, among the sides still `free`. Where the pose
/// model sees the person: the side whose pose wrist is nearer among the arms that reach it
/// ([`reaches`]; a palm out of both arms' reach is someone else's). Where it does not
/// ([`no_body`]: a face close up, on which it finds no body or misreads one) but
/// the face mesh does: the side of the face's midline the wrist is on (an arm comes up from its
/// own shoulder, below the frame), for a wrist within [`FACE_REACH`] of the face.
fn palm_side(
    pose: &PoseKeypoints,
    face: Option<&FaceLandmarks>,
    wrist: Vec2,
    free: impl Fn(Side) -> bool,
) -> Option<Side> {
    if no_body(pose, face).is_none() {
        let pose_wrist = |side| pose.point(if side == Side::Left { 15 } else { 16 }).0;
        let d = |s| pose_wrist(s).distance(wrist);
        return [Side::Left, Side::Right]
            .into_iter()
            .filter(|&s| free(s) && reaches(pose, s, wrist))
            .min_by(|&a, &b| d(a).total_cmp(&d(b)));
    }
    let face = face?;
    let roi = Roi::face_from_landmarks(&face.points);
    let across = face.points[FACE_EYE_CORNERS.1] - face.points[FACE_EYE_CORNERS.0];
    let off = wrist - roi.centre;
    // The eye corners run from the person's right to their left.
    let side = if off.dot(across) > 0.0 {
        Side::Left
    } else {
        Side::Right
    };
    (off.length() <= FACE_REACH * roi.side && free(side)).then_some(side)
}

/// A palm may lie this many face crops ([`Roi::face_from_landmarks`]) from the face's centre
/// and still be the hand of the person whose face it is, when the pose model sees no body.
const FACE_REACH: f32 = 1.5;

/// A palm's wrist may lie this many arm lengths from the shoulder and still be that arm's hand.
const REACH: f32 = 1.3;
/// An arm (shoulder to wrist) is at least this many shoulder widths, however foreshortened.
const ARM_PER_SHOULDER_WIDTH: f32 = 1.6;

/// Whether the subject's `side` arm reaches `at`: within [`REACH`] arm lengths of its shoulder,
/// the arm's length being its upper arm and forearm as the pose model places them, or
/// [`ARM_PER_SHOULDER_WIDTH`] shoulder widths when that is more (an arm pointing at the camera).
fn reaches(pose: &PoseKeypoints, side: Side, at: Vec2) -> bool {
    let joints = match side {
        Side::Left => [11, 13, 15],
        Side::Right => [12, 14, 16],
    };
    let [shoulder, elbow, wrist] = joints.map(|i| pose.point(i).0);
    let width = pose.point(11).0.distance(pose.point(12).0);
    let arm =
        (shoulder.distance(elbow) + elbow.distance(wrist)).max(ARM_PER_SHOULDER_WIDTH * width);
    shoulder.distance(at) <= REACH * arm
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}
