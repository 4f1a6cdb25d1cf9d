//! The 468-point face mesh from MediaPipe's face landmark model (`face_landmark`): a 192² crop
//! with the eyes level (RGB in [0, 1], NHWC) in; the points in input pixels (x, y, relative
//! depth) and a face-presence logit out.

use std::path::Path;

use glam::Vec2;

use super::model::SquareModel;
use super::{Roi, sigmoid};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::SourceImage;

pub const FACE_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/face_landmark.onnx"
);
pub const FACE_INPUT: usize = 192;
pub const FACE_POINTS: usize = 468;
/// The outer eye corners (subject's right, subject's left): MediaPipe levels the crop by them.
pub const FACE_EYE_CORNERS: (usize, usize) = (33, 263);
/// The nose tip, and each eye's two corners (their midpoint is the eye; the person's left is
/// MediaPipe's left, the image's right).
pub const FACE_NOSE: usize = 1;
pub const FACE_LEFT_EYE: [usize; 2] = [362, 263];
pub const FACE_RIGHT_EYE: [usize; 2] = [33, 133];
/// Below this presence the crop holds no face (MediaPipe's tracking threshold).
const MIN_PRESENCE: f32 = 0.5;

/// A face mesh found on a photo.
#[derive(Clone, Debug, PartialEq)]
pub struct FaceLandmarks {
    /// The 468 points in the source's pixel-edge coordinates.
    pub points: Vec<Vec2>,
    /// sigmoid of the model's face logit on the final crop.
    pub presence: f32,
    /// The crop the points came from.
    pub roi: Roi,
}

pub struct FaceLandmarker {
    model: SquareModel,
}

impl FaceLandmarker {
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(FACE_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        let what = "MediaPipe's face landmark model";
        Ok(Self {
            model: SquareModel::load(runtime, path, what, 2, FACE_INPUT)?,
        })
    }

    /// Runs the model on a 192² RGB input in [0, 1]: the points in input pixels and the
    /// presence probability.
    pub fn run(&mut self, input: &[f32]) -> Result<(Vec<[f32; 3]>, f32), OnnxError> {
        let outputs = self.model.run(input)?;
        let points = self.model.output(&outputs, FACE_POINTS * 3, "landmark")?;
        let logit = self.model.output(&outputs, 1, "face flag")?[0];
        let points = points.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        Ok((points, sigmoid(logit)))
    }

    /// The face mesh in `roi` of the source, refined once by re-cropping around the first
    /// answer (as MediaPipe's tracking does between frames); `None` if no face is there.
    pub fn detect(
        &mut self,
        source: &SourceImage,
        roi: Roi,
    ) -> Result<Option<FaceLandmarks>, OnnxError> {
        self.detect_passes(source, roi, 2)
    }

    /// The face mesh in `roi` after `passes` crops (each placed by the last answer): a video's
    /// next frame takes one, in the crop its last frame's mesh places.
    pub fn detect_passes(
        &mut self,
        source: &SourceImage,
        roi: Roi,
        passes: usize,
    ) -> Result<Option<FaceLandmarks>, OnnxError> {
        let found = roi.track(
            source,
            FACE_INPUT,
            MIN_PRESENCE,
            passes,
            |x| self.run(x),
            Roi::face_from_landmarks,
        )?;
        Ok(found.map(|(points, presence, roi)| FaceLandmarks {
            points,
            presence,
            roi,
        }))
    }
}
