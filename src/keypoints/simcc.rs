//! Keypoints from an RTMPose-style SimCC model (EHM-Tracker's DWPose, `dw-ll_ucoco_384.onnx`),
//! prepared and decoded exactly as EHM-Tracker's `onnxpose.py` does: the person's box grown by
//! 1.25 and widened or heightened to the input's aspect, warped to the input (bilinear at 1/32
//! pixel steps, black outside the photo, 8-bit), normalised by ImageNet's mean and std (RGB,
//! NCHW); per keypoint a row of x bins and a row of y bins, each point at its rows' first
//! maxima, its score the smaller of the two maxima. Coordinates are EHM-Tracker's: pixel centres
//! at integers.

use std::path::Path;

use glam::{DVec2, Vec2};

use super::model::{NchwModel, Rgb8};
use crate::onnx::{OnnxError, OnnxRuntime};

const PADDING: f64 = 1.25;
const MEAN: [f32; 3] = [123.675, 116.28, 103.53];
const STD: [f32; 3] = [58.395, 57.12, 57.375];

/// The crop a SimCC model saw: its centre and its size in the photo (after padding and aspect).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimccCrop {
    pub centre: DVec2,
    pub scale: DVec2,
}

/// What a SimCC model found in one crop.
#[derive(Clone, Debug, PartialEq)]
pub struct SimccPoints {
    pub crop: SimccCrop,
    /// Each keypoint in the photo, EHM-Tracker's pixel coordinates; (−1, −1) in the crop when the
    /// model scored it 0 or less, as there.
    pub points: Vec<Vec2>,
    pub scores: Vec<f32>,
}

pub struct SimccLandmarker {
    model: NchwModel,
}

impl SimccLandmarker {
    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        let what = "EHM-Tracker's whole-body keypoint model (DWPose: SimCC x and y outputs)";
        Ok(Self {
            model: NchwModel::load(runtime, path, what, 2)?,
        })
    }

    pub fn path(&self) -> &Path {
        self.model.path()
    }

    /// The crop for a box (left, top, right, bottom), or for the whole photo without one.
    pub fn crop(&self, photo: &Rgb8, corners: Option<[f32; 4]>) -> SimccCrop {
        let side = photo.side as f32;
        let [x0, y0, x1, y1] = corners.unwrap_or([0.0, 0.0, side, side]).map(f64::from);
        let centre = DVec2::new(x0 + x1, y0 + y1) * 0.5;
        let (w, h) = ((x1 - x0) * PADDING, (y1 - y0) * PADDING);
        let aspect = self.model.width as f64 / self.model.height as f64;
        let scale = if w > h * aspect {
            DVec2::new(w, w / aspect)
        } else {
            DVec2::new(h * aspect, h)
        };
        SimccCrop { centre, scale }
    }

    /// The model's input for a crop (NCHW, normalised): OpenCV's `warpAffine` on 8-bit pixels
    /// to the bit (checked against it): the map from `onnxpose.py`'s three points (float32),
    /// each sample placed at 1/32 pixel by its 10-bit fixed-point sums, 4 exact bilinear
    /// weights, black outside the photo.
    pub fn input(&self, photo: &Rgb8, crop: SimccCrop) -> Vec<f32> {
        let (w, h) = (self.model.width, self.model.height);
        let (side, rgb) = (photo.side, &photo.rgb);
        let map = InverseMap::of(crop, w, h);
        let mut planes = vec![0.0; 3 * w * h];
        for y in 0..h {
            for x in 0..w {
                let (sx, sy, fx, fy) = map.sample(x, y);
                let tap = |dx: i64, dy: i64, c: usize| {
                    let (xx, yy) = (sx + dx, sy + dy);
                    if xx < 0 || yy < 0 || xx >= side as i64 || yy >= side as i64 {
                        0.0
                    } else {
                        rgb[3 * (yy as usize * side + xx as usize) + c] as f32
                    }
                };
                for c in 0..3 {
                    // Exact in f32: 8-bit values times 5-bit fractions.
                    let top = tap(0, 0, c) * (1.0 - fx) + tap(1, 0, c) * fx;
                    let bottom = tap(0, 1, c) * (1.0 - fx) + tap(1, 1, c) * fx;
                    let value = (top * (1.0 - fy) + bottom * fy + 0.5).floor();
                    planes[(c * h + y) * w + x] = (value - MEAN[c]) / STD[c];
                }
            }
        }
        planes
    }

    /// The keypoints in the crop of a box (left, top, right, bottom), or of the whole photo.
    pub fn detect(
        &mut self,
        photo: &Rgb8,
        corners: Option<[f32; 4]>,
    ) -> Result<SimccPoints, OnnxError> {
        let crop = self.crop(photo, corners);
        let outputs = self.model.run(self.input(photo, crop))?;
        let (w, h) = (self.model.width, self.model.height);
        let (x, y) = (&outputs[0], &outputs[1]);
        let (bins_x, bins_y) = (
            x.shape.last().copied().unwrap_or(0),
            y.shape.last().copied().unwrap_or(0),
        );
        // The bins per input pixel (DWPose's 2): the same along x and y.
        let split = bins_x as f64 / w as f64;
        let points = x.data.len().checked_div(bins_x).unwrap_or(0);
        if bins_x == 0 || bins_y as f64 != split * h as f64 || y.data.len() != points * bins_y {
            return Err(OnnxError::Run {
                path: self.model.path().to_path_buf(),
                reason: format!(
                    "expected x and y bins in the input's {w}×{h} proportion for the same \
                     keypoints, found outputs of shapes {:?} and {:?}",
                    x.shape, y.shape
                ),
            });
        }
        Ok(decode(
            &x.data,
            &y.data,
            [bins_x, bins_y],
            split,
            crop,
            [w, h],
        ))
    }
}

/// Where each input pixel samples the photo, as `warpAffine` computes it.
struct InverseMap {
    per_pixel: [f64; 2],
    offset: [f64; 2],
}

impl InverseMap {
    /// `get_warp_matrix` without rotation: the crop's centre and the point half its width above
    /// it (float32) go to the input's centre and the point half the input's width above that,
    /// the third point a quarter turn on.
    fn of(crop: SimccCrop, w: usize, h: usize) -> Self {
        let centre = crop.centre.as_vec2();
        let above = (crop.centre.y - crop.scale.x / 2.0) as f32;
        let dy = centre.y - above;
        let third = centre.x - dy;
        let half = w as f64 / 2.0;
        let per_pixel = [(centre.x - third) as f64 / half, dy as f64 / half];
        Self {
            per_pixel,
            offset: [
                centre.x as f64 - half * per_pixel[0],
                centre.y as f64 - h as f64 / 2.0 * per_pixel[1],
            ],
        }
    }

    /// The source pixel left of and above input pixel (x, y)'s sample, and the sample's
    /// fractions: `warpAffine` works in 1/1024 pixel, rounding the row's term (y's share and the
    /// offsets) and each column's term (x's share) apart, and keeps 1/32.
    fn sample(&self, x: usize, y: usize) -> (i64, i64, f32, f32) {
        let fixed = |v: f64| (v * 1024.0).round_ties_even() as i64;
        let x = fixed(self.offset[0]) + fixed(self.per_pixel[0] * x as f64) + 16;
        let y = fixed(self.per_pixel[1] * y as f64 + self.offset[1]) + 16;
        let (x, y) = (x >> 5, y >> 5);
        (
            x >> 5,
            y >> 5,
            (x & 31) as f32 / 32.0,
            (y & 31) as f32 / 32.0,
        )
    }
}

/// `onnxpose.py`'s `decode` and `postprocess`.
fn decode(
    x: &[f32],
    y: &[f32],
    [bins_x, bins_y]: [usize; 2],
    split: f64,
    crop: SimccCrop,
    [w, h]: [usize; 2],
) -> SimccPoints {
    // numpy's argmax: the first of equal maxima.
    let peak = |row: &[f32]| {
        row.iter()
            .enumerate()
            .fold((0, f32::NEG_INFINITY), |best, (i, &v)| {
                if v > best.1 { (i, v) } else { best }
            })
    };
    let size = DVec2::new(w as f64, h as f64);
    let (points, scores) = x
        .chunks_exact(bins_x)
        .zip(y.chunks_exact(bins_y))
        .map(|(rx, ry)| {
            let ((ix, vx), (iy, vy)) = (peak(rx), peak(ry));
            let score = vx.min(vy);
            let at = if score > 0.0 {
                DVec2::new(ix as f64, iy as f64)
            } else {
                DVec2::splat(-1.0)
            } / split;
            let photo = at / size * crop.scale + crop.centre - crop.scale / 2.0;
            (photo.as_vec2(), score)
        })
        .unzip();
    SimccPoints {
        crop,
        points,
        scores,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decoding_takes_the_first_peaks_and_the_weaker_score() {
        let crop = SimccCrop {
            centre: DVec2::new(100.0, 50.0),
            scale: DVec2::new(40.0, 80.0),
        };
        // One point on a 4 × 8 input at 2 bins per pixel: x peaks (twice) at bin 3, y at bin 10;
        // a second point the model scores 0.
        let mut x = vec![0.0; 16];
        let mut y = vec![0.0; 32];
        (x[3], x[5], y[10]) = (0.9, 0.9, 0.6);
        let found = decode(&x, &y, [8, 16], 2.0, crop, [4, 8]);
        assert_eq!(found.scores, vec![0.6, 0.0]);
        // x: bin 3 → 1.5 input pixels of 4 → 15 of the crop's 40, from its left edge at 80;
        // y: bin 10 → 5 of 8 → 50 of 80, from its top edge at 10.
        assert_eq!(found.points[0], Vec2::new(95.0, 60.0));
        // Unscored: bin −1 → −0.5 input pixels → 5 crop pixels before each edge.
        assert_eq!(found.points[1], Vec2::new(75.0, 5.0));
    }
}
