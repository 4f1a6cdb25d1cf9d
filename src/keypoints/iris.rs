//! Iris centres and eyelids from MediaPipe's iris landmark model (`iris_landmark`): a 64² crop
//! around one eye (RGB in [0, 1], NHWC) in; 71 eye-contour and brow points and 5 iris points (the
//! centre, then four on the rim) in input pixels out. The crop is placed as MediaPipe's iris graph
//! places it, by the face mesh's two corners of that eye. The model knows only the subject's right
//! eye (on the image's left), so the left eye's crop is mirrored in and its points mirrored back.
//!
//! Its first 16 contour points are the eyelids' margins, which replace the face mesh's own
//! between the corners, as MediaPipe's refined face mesh has them: from its crop of the whole
//! face the face mesh leaves shut eyes open, and the fit took the clip's shut eyes for open ones
//! (`shut_eyes_are_fitted_shut` in tests/fit.rs). The corners stay the face mesh's, which placed
//! the crop: the eye's place and span are what the face's fit sizes the head by, and the model's
//! own corners on a drawn eye put the drawn head's shoulders 15 px off (`tests/framing.rs`).

use std::path::Path;

use glam::Vec2;

use super::model::SquareModel;
use super::{FaceLandmarks, Roi, Side};
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::SourceImage;

pub const IRIS_MODEL_PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/models/iris_landmark.onnx"
);
pub const IRIS_INPUT: usize = 64;
const CONTOUR_POINTS: usize = 71;
const IRIS_POINTS: usize = 5;
/// MediaPipe's crop: 2.3× the eye corners' longer extent (`IrisLandmarkLandmarksToRoi`).
const EYE_CROP_SCALE: f32 = 2.3;
/// Each eye's face-mesh points that the model's first 16 contour points stand for (lower lid
/// from corner to corner, then the upper lid between them; `UpdateFaceLandmarks`'s table), for
/// the eye the model sees: the subject's right eye, and its mirror image, the left. Points 0 and
/// 8 are the corners, which place the crop.
const EYES: [(Side, [usize; EYELID_POINTS]); 2] = [
    (
        Side::Right,
        [
            33, 7, 163, 144, 145, 153, 154, 155, 133, 246, 161, 160, 159, 158, 157, 173,
        ],
    ),
    (
        Side::Left,
        [
            263, 249, 390, 373, 374, 380, 381, 382, 362, 466, 388, 387, 386, 385, 384, 398,
        ],
    ),
];
const EYELID_POINTS: usize = 16;

/// One eye's iris found on a photo.
#[derive(Clone, Debug, PartialEq)]
pub struct Iris {
    pub side: Side,
    /// The iris centre in the source's pixel-edge coordinates.
    pub centre: Vec2,
    /// Its mean radius in source pixels (centre to the four rim points).
    pub radius: f32,
    /// The crop the points came from.
    pub roi: Roi,
}

/// Model output points in input pixels (x, y, relative depth).
pub type Points = Vec<[f32; 3]>;

pub struct IrisLandmarker {
    model: SquareModel,
}

impl IrisLandmarker {
    pub fn load(runtime: &OnnxRuntime) -> Result<Self, OnnxError> {
        Self::load_from(runtime, Path::new(IRIS_MODEL_PATH))
    }

    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        let what = "MediaPipe's iris landmark model";
        Ok(Self {
            model: SquareModel::load(runtime, path, what, 2, IRIS_INPUT)?,
        })
    }

    /// Runs the model on a 64² RGB input in [0, 1] showing a right eye: the 71 contour points
    /// and the 5 iris points, in input pixels.
    pub fn run(&mut self, input: &[f32]) -> Result<(Points, Points), OnnxError> {
        let outputs = self.model.run(input)?;
        let rows = |v: &[f32]| v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let contour = rows(
            self.model
                .output(&outputs, CONTOUR_POINTS * 3, "eye contour")?,
        );
        let iris = rows(self.model.output(&outputs, IRIS_POINTS * 3, "iris")?);
        Ok((contour, iris))
    }

    /// Both irises in the eyes of a face mesh found on `source`; the face mesh's eyelid points
    /// between the corners move to where the iris model finds the lids.
    pub fn detect(
        &mut self,
        source: &SourceImage,
        face: &mut FaceLandmarks,
    ) -> Result<Vec<Iris>, OnnxError> {
        EYES.iter()
            .map(|&(side, lids)| {
                let mirrored = side == Side::Left;
                // The image-left corner first (upright): the right eye's outer, the left's inner.
                let [a, b] = match mirrored {
                    false => [lids[0], lids[8]],
                    true => [lids[8], lids[0]],
                };
                let roi = Roi::eye(face.points[a], face.points[b], EYE_CROP_SCALE);
                let mut input = roi.sample(source, IRIS_INPUT);
                if mirrored {
                    mirror_rows(&mut input, IRIS_INPUT);
                }
                let (contour, iris) = self.run(&input)?;
                let to_image = |p: &[f32; 3]| {
                    let x = if mirrored {
                        IRIS_INPUT as f32 - p[0]
                    } else {
                        p[0]
                    };
                    roi.to_image(Vec2::new(x, p[1]), IRIS_INPUT)
                };
                for (&i, p) in lids
                    .iter()
                    .zip(&contour)
                    .filter(|(i, _)| **i != a && **i != b)
                {
                    face.points[i] = to_image(p);
                }
                let centre = to_image(&iris[0]);
                let radius = iris[1..]
                    .iter()
                    .map(|p| to_image(p).distance(centre))
                    .sum::<f32>()
                    / (IRIS_POINTS - 1) as f32;
                Ok(Iris {
                    side,
                    centre,
                    radius,
                    roi,
                })
            })
            .collect()
    }
}

/// Mirrors an `n`² interleaved RGB image left to right.
fn mirror_rows(rgb: &mut [f32], n: usize) {
    for row in rgb.chunks_exact_mut(3 * n) {
        for x in 0..n / 2 {
            for c in 0..3 {
                row.swap(3 * x + c, 3 * (n - 1 - x) + c);
            }
        }
    }
}
