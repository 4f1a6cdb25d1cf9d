//! What a fit reports: each stage's points as the models found them and where the fitted body
//! puts them, their errors, and what each point is on the body (to re-project it when the pose
//! is adjusted by hand).

use glam::Vec2;

use super::BodyPoint;
use crate::body::Landmark;
use crate::keypoints::Side;

#[derive(Clone, Debug, PartialEq)]
pub struct FitReport {
    pub keypoints_used: usize,
    pub iterations: usize,
    /// Root-mean-square reprojection error of the used body keypoints, in pixels (without the
    /// lower body's when the legs rest, [`Self::legs_at_rest`]).
    pub rms_px: f32,
    /// Each used body keypoint as the model found it, and where the fitted body puts it (source
    /// pixels).
    pub observed: Vec<Vec2>,
    pub fitted: Vec<Vec2>,
    /// What each used body keypoint is on the body, to re-project it when the pose is adjusted.
    pub surface: Vec<Landmark>,
    /// The face stage, when it ran.
    pub face: Option<FaceFitReport>,
    /// Why the face stage did not run, when it did not.
    pub face_skipped: Option<String>,
    /// The hand stage, when the hand model found a hand.
    pub hands: Option<HandFitReport>,
    /// Why the pose model's body was not used, when it was not (no person, or points that
    /// contradict the face): the head's keypoints came from the face mesh and the shoulders'
    /// from the person mask.
    pub body_from_face: Option<String>,
    /// The arms whose elbow and wrist the keypoint models did not see ("left", "right": the
    /// person's): they rest along the body.
    pub unseen_arms: Vec<&'static str>,
    /// No knee was seen confidently: the legs rest, and the lower body's points (which steer
    /// the torso) are left out of the RMS.
    pub legs_at_rest: bool,
    /// The gaze stage, when the face stage ran, the iris model found irises and the body has
    /// eye joints and eyeballs with an iris part ([`super::pupil`]).
    pub gaze: Option<GazeFitReport>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct GazeFitReport {
    /// Which eye each entry is, in the order of every list here.
    pub sides: Vec<Side>,
    /// Root-mean-square error of the iris centres before and after the gaze stage, with the eyes'
    /// feature offsets.
    pub rms_before_px: f32,
    pub rms_px: f32,
    /// Each iris centre as the model found it, and where the fitted body's pupil is (source
    /// pixels, without the offsets).
    pub observed: Vec<Vec2>,
    pub fitted: Vec<Vec2>,
    /// The pupils on the body, to re-project them when the pose is adjusted.
    pub pupils: Vec<Landmark>,
    /// Each eye's turn from rest (radians).
    pub turn_rad: Vec<f32>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct HandFitReport {
    pub hands: usize,
    pub iterations: usize,
    /// Root-mean-square reprojection error of the hand points before and after the hand stage.
    pub rms_before_px: f32,
    pub rms_px: f32,
    /// Each hand point as the model found it, and where the fitted body puts it (source pixels).
    pub observed: Vec<Vec2>,
    pub fitted: Vec<Vec2>,
    /// What each point is on the body, to re-project it when the pose is adjusted.
    pub targets: Vec<BodyPoint>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct FaceFitReport {
    pub points_used: usize,
    pub iterations: usize,
    /// Root-mean-square reprojection error of the face points before and after the face stage
    /// (after: with the features' offsets).
    pub rms_before_px: f32,
    pub rms_px: f32,
    /// The fitted [`HEAD_SIZE`] coefficient (the head is 1 + this times the template's), when the
    /// body has the target.
    pub head_size: Option<f32>,
    /// Each used face point as the model found it and where the fitted body itself puts it
    /// (source pixels, without the features' offsets), for showing over the photo.
    pub observed: Vec<Vec2>,
    pub fitted: Vec<Vec2>,
    /// The used points' places on the body (from the [`FaceEmbedding`]), to re-project them
    /// when the pose is adjusted.
    pub surface: Vec<Landmark>,
    /// How far each facial feature ([`super::FACE_FEATURES`]) sits in the image from where the
    /// default face has it: the person's, kept when a video's later frames are fitted.
    pub feature_offsets: [Vec2; super::FACE_FEATURES.len()],
}
