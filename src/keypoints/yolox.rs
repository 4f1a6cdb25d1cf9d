//! People on a photo from YOLOX (EHM-Tracker's `yolox_l.onnx`), prepared and decoded exactly as
//! EHM-Tracker's `onnxdet.py` does: the photo scaled to fit the input (bilinear, 8-bit, grey 114
//! around it, RGB values 0–255, NCHW); per cell of the stride 8, 16 and 32 grids a box (centre
//! offset in cells, log size), an objectness and 80 class scores (after sigmoid); boxes of the
//! person class scoring over 0.1 thinned by non-maximum suppression at IoU 0.45, then those over
//! 0.3 kept. Coordinates are EHM-Tracker's: pixel centres at integers.

use std::path::Path;

use super::model::{NchwModel, Rgb8};
use crate::onnx::{OnnxError, OnnxRuntime};

const STRIDES: [usize; 3] = [8, 16, 32];
const ROW: usize = 85;
const PAD: f32 = 114.0;
const CANDIDATE_SCORE: f32 = 0.1;
const NMS_IOU: f32 = 0.45;
const PERSON_SCORE: f32 = 0.3;

/// A person's box (left, top, right, bottom) in EHM-Tracker's pixel coordinates, with its score.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PersonBox {
    pub corners: [f32; 4],
    pub score: f32,
}

pub struct PersonDetector {
    model: NchwModel,
}

impl PersonDetector {
    pub fn load_from(runtime: &OnnxRuntime, path: &Path) -> Result<Self, OnnxError> {
        let what = "EHM-Tracker's person detector (YOLOX, one output of 85 values per cell)";
        Ok(Self {
            model: NchwModel::load(runtime, path, what, 1)?,
        })
    }

    /// The people on the photo, best first.
    pub fn detect(&mut self, photo: &Rgb8) -> Result<Vec<PersonBox>, OnnxError> {
        let (input, ratio) = self.letterbox(photo);
        let outputs = self.model.run(input)?;
        let (w, h) = (self.model.width, self.model.height);
        let cells: usize = STRIDES.iter().map(|s| (w / s) * (h / s)).sum();
        let rows = &outputs[0].data;
        if rows.len() != cells * ROW {
            return Err(OnnxError::Run {
                path: self.model.path().to_path_buf(),
                reason: format!(
                    "expected {cells} rows of {ROW} values (the stride 8, 16 and 32 grids of a \
                     {w}×{h} input), found {} values",
                    rows.len()
                ),
            });
        }
        Ok(decode(rows, w, h, ratio))
    }

    /// The model's input and the photo's scale in it: the photo scaled by the largest factor
    /// that fits, top left, grey around it. The scaling is OpenCV's bilinear `resize` on 8-bit
    /// pixels to the bit (checked against it): half-pixel centres; weights in 11-bit fixed
    /// point; columns past the edge clamped with their weight, rows past it only clamped; the
    /// vertical pass as its vector code rounds it.
    fn letterbox(&self, photo: &Rgb8) -> (Vec<f32>, f32) {
        let (w, h) = (self.model.width, self.model.height);
        let (side, rgb) = (photo.side, &photo.rgb);
        let ratio = (w as f32 / side as f32).min(h as f32 / side as f32);
        let inner = (side as f32 * ratio) as usize;
        let mut planes = vec![PAD; 3 * w * h];
        // Source indices and 11-bit weights of output index d; `clamp_weight` zeroes the weight
        // past the edges (OpenCV does so along x, not y).
        let taps = |d: usize, clamp_weight: bool| {
            let f = ((d as f64 + 0.5) * (side as f64 / inner as f64) - 0.5) as f32;
            let s = f.floor();
            let mut frac = f - s;
            if clamp_weight && (s < 0.0 || s as usize >= side - 1) {
                frac = 0.0;
            }
            let at = |k: f32| (k.max(0.0) as usize).min(side - 1);
            let weight = |v: f32| (v * 2048.0).round_ties_even() as i32;
            (at(s), at(s + 1.0), weight(1.0 - frac), weight(frac))
        };
        let columns: Vec<_> = (0..inner.min(w)).map(|x| taps(x, true)).collect();
        let across = |row: usize, c: usize| -> Vec<i32> {
            let px = |x: usize| rgb[3 * (row * side + x) + c] as i32;
            columns
                .iter()
                .map(|&(x0, x1, a0, a1)| px(x0) * a0 + px(x1) * a1)
                .collect()
        };
        for y in 0..inner.min(h) {
            let (y0, y1, b0, b1) = taps(y, false);
            for c in 0..3 {
                let (top, bottom) = (across(y0, c), across(y1, c));
                for (x, (t, b)) in top.iter().zip(&bottom).enumerate() {
                    let v = (((b0 * (t >> 4)) >> 16) + ((b1 * (b >> 4)) >> 16) + 2) >> 2;
                    planes[(c * h + y) * w + x] = v.clamp(0, 255) as f32;
                }
            }
        }
        (planes, ratio)
    }
}

/// The model's rows (`onnxdet.py`'s `demo_postprocess` and `multiclass_nms`, person class only:
/// the suppression is per class, so the other classes never affect it) as boxes in the photo.
fn decode(rows: &[f32], w: usize, h: usize, ratio: f32) -> Vec<PersonBox> {
    let mut candidates = Vec::new();
    let mut row = rows.chunks_exact(ROW);
    for stride in STRIDES {
        let s = stride as f32;
        for gy in 0..h / stride {
            for gx in 0..w / stride {
                let r = row.next().expect("row count checked");
                let score = r[4] * r[5];
                if score <= CANDIDATE_SCORE {
                    continue;
                }
                let (cx, cy) = ((r[0] + gx as f32) * s, (r[1] + gy as f32) * s);
                let (bw, bh) = (r[2].exp() * s, r[3].exp() * s);
                let corners =
                    [cx - bw / 2.0, cy - bh / 2.0, cx + bw / 2.0, cy + bh / 2.0].map(|v| v / ratio);
                candidates.push(PersonBox { corners, score });
            }
        }
    }
    suppress(candidates)
        .into_iter()
        .filter(|b| b.score > PERSON_SCORE)
        .collect()
}

/// Greedy non-maximum suppression, best first; areas and overlaps count the `+ 1` pixel of
/// `onnxdet.py`'s `nms`, and a box survives an overlap of exactly the threshold.
fn suppress(mut boxes: Vec<PersonBox>) -> Vec<PersonBox> {
    boxes.sort_by(|a, b| b.score.total_cmp(&a.score));
    let area = |b: &[f32; 4]| (b[2] - b[0] + 1.0) * (b[3] - b[1] + 1.0);
    let mut kept: Vec<PersonBox> = Vec::new();
    for b in boxes {
        let overlaps = kept.iter().any(|k| {
            let (a, c) = (&k.corners, &b.corners);
            let iw = (a[2].min(c[2]) - a[0].max(c[0]) + 1.0).max(0.0);
            let ih = (a[3].min(c[3]) - a[1].max(c[1]) + 1.0).max(0.0);
            let inter = iw * ih;
            inter / (area(a) + area(c) - inter) > NMS_IOU
        });
        if !overlaps {
            kept.push(b);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    fn person(corners: [f32; 4], score: f32) -> PersonBox {
        PersonBox { corners, score }
    }

    #[test]
    fn suppression_keeps_the_best_of_each_overlapping_group() {
        let boxes = vec![
            person([0.0, 0.0, 9.0, 9.0], 0.5),
            person([1.0, 1.0, 10.0, 10.0], 0.9),
            person([30.0, 30.0, 39.0, 39.0], 0.4),
        ];
        let kept = suppress(boxes);
        assert_eq!(
            kept,
            vec![
                person([1.0, 1.0, 10.0, 10.0], 0.9),
                person([30.0, 30.0, 39.0, 39.0], 0.4),
            ]
        );
    }
}
