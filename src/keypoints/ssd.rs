//! MediaPipe's single-shot detectors (the pose and palm detectors) decoded as its graphs decode
//! them: fixed-size SSD anchors (`SsdAnchorsCalculator`), per anchor a box and keypoints as
//! offsets in input pixels (`TensorsToDetectionsCalculator`, box centre first), scores as
//! logits clipped to ±100, and weighted non-maximum suppression (`NonMaxSuppressionCalculator`,
//! `WEIGHTED`): each cluster of boxes overlapping its best one by IoU > 0.3 becomes one
//! detection, its box and keypoints averaged by score.

use std::path::Path;

use glam::Vec2;

use super::Roi;
use super::model::SquareModel;
use crate::onnx::{OnnxError, OnnxRuntime};
use crate::photo::SourceImage;

/// Boxes overlapping a cluster's best one by more than this (IoU) join the cluster.
const NMS_OVERLAP: f32 = 0.3;

/// A detector's anchor layout and output layout.
pub(super) struct SsdLayout {
    /// The square input's side.
    pub input: usize,
    /// (stride, anchors per cell) of each grid; layers of one stride share a grid.
    pub grids: &'static [(usize, usize)],
    pub keypoints: usize,
}

/// One detection, in [0, 1] of the input.
#[derive(Clone, Debug, PartialEq)]
pub struct Detection {
    pub score: f32,
    /// The box's corners (top-left, bottom-right).
    pub bounds: [Vec2; 2],
    pub keypoints: Vec<Vec2>,
}

pub(super) struct Ssd {
    layout: SsdLayout,
    /// Anchor centres in [0, 1] of the input.
    anchors: Vec<Vec2>,
}

impl Ssd {
    pub fn new(layout: SsdLayout) -> Self {
        let mut anchors = Vec::new();
        for &(stride, per_cell) in layout.grids {
            let cells = layout.input.div_ceil(stride);
            for y in 0..cells {
                for x in 0..cells {
                    let centre = Vec2::new(
                        (x as f32 + 0.5) / cells as f32,
                        (y as f32 + 0.5) / cells as f32,
                    );
                    anchors.extend(std::iter::repeat_n(centre, per_cell));
                }
            }
        }
        Self { layout, anchors }
    }

    pub fn anchors(&self) -> usize {
        self.anchors.len()
    }

    /// Values per anchor: the box (centre, size), then two per keypoint.
    pub fn values(&self) -> usize {
        4 + 2 * self.layout.keypoints
    }

    /// Up to `max` detections scoring at least `min_score`, best first.
    pub fn decode(
        &self,
        boxes: &[f32],
        logits: &[f32],
        min_score: f32,
        max: usize,
    ) -> Vec<Detection> {
        let (n, values) = (self.layout.input as f32, self.values());
        let score = |i: usize| 1.0 / (1.0 + (-logits[i].clamp(-100.0, 100.0)).exp());
        let mut candidates: Vec<Detection> = (0..self.anchors.len())
            .filter(|&i| logits[i].is_finite() && score(i) >= min_score)
            .map(|i| {
                let v = &boxes[i * values..(i + 1) * values];
                let at = |k: usize| self.anchors[i] + Vec2::new(v[k], v[k + 1]) / n;
                let half = Vec2::new(v[2], v[3]) / n / 2.0;
                let centre = at(0);
                Detection {
                    score: score(i),
                    bounds: [centre - half, centre + half],
                    keypoints: (0..self.layout.keypoints).map(|k| at(4 + 2 * k)).collect(),
                }
            })
            .collect();
        candidates.sort_by(|a, b| b.score.total_cmp(&a.score));
        let mut out = Vec::new();
        while let Some(best) = candidates.first().cloned() {
            if out.len() == max {
                break;
            }
            let (cluster, rest): (Vec<_>, Vec<_>) = candidates
                .into_iter()
                .partition(|d| iou(d.bounds, best.bounds) > NMS_OVERLAP);
            candidates = rest;
            let weight: f32 = cluster.iter().map(|d| d.score).sum();
            let mean = |f: &dyn Fn(&Detection) -> Vec2| {
                cluster.iter().map(|d| d.score * f(d)).sum::<Vec2>() / weight
            };
            out.push(Detection {
                score: best.score,
                bounds: [mean(&|d| d.bounds[0]), mean(&|d| d.bounds[1])],
                keypoints: (0..self.layout.keypoints)
                    .map(|k| mean(&|d| d.keypoints[k]))
                    .collect(),
            });
        }
        out
    }
}

/// A detector model with its layout: the whole photo in, detections out.
pub(super) struct SsdModel {
    model: SquareModel,
    ssd: Ssd,
    /// Whether the model takes RGB in [-1, 1] (else [0, 1]).
    signed_input: bool,
}

impl SsdModel {
    /// `what` names the model in errors.
    pub fn load(
        runtime: &OnnxRuntime,
        path: &Path,
        what: &str,
        layout: SsdLayout,
        signed_input: bool,
    ) -> Result<Self, OnnxError> {
        Ok(Self {
            model: SquareModel::load(runtime, path, what, 2, layout.input)?,
            ssd: Ssd::new(layout),
            signed_input,
        })
    }

    /// The raw outputs for an input of the model's side and range: per anchor the box and
    /// keypoint values, and the score logits.
    pub fn run(&mut self, input: &[f32]) -> Result<(Vec<f32>, Vec<f32>), OnnxError> {
        let outputs = self.model.run(input)?;
        let (anchors, values) = (self.ssd.anchors(), self.ssd.values());
        let boxes = self.model.output(&outputs, anchors * values, "box")?;
        let scores = self.model.output(&outputs, anchors, "score")?;
        Ok((boxes.to_vec(), scores.to_vec()))
    }

    pub fn decode(
        &self,
        boxes: &[f32],
        logits: &[f32],
        min_score: f32,
        max: usize,
    ) -> Vec<Detection> {
        self.ssd.decode(boxes, logits, min_score, max)
    }

    /// Up to `max` detections on a square source image, in its pixels, best first.
    pub fn detect(
        &mut self,
        source: &SourceImage,
        min_score: f32,
        max: usize,
    ) -> Result<Vec<Detection>, OnnxError> {
        self.detect_tiers(source, &[min_score], max)
    }

    /// [`Self::detect`] at each of `scores` in turn (highest first): a lower tier adds only the
    /// detections that overlap none found already. Each tier averages its clusters over its own
    /// anchors, so weak anchors around a confident detection do not move it (the cameraman's
    /// pose crop shifted onto his shoulder when they were averaged in).
    pub fn detect_tiers(
        &mut self,
        source: &SourceImage,
        scores: &[f32],
        max: usize,
    ) -> Result<Vec<Detection>, OnnxError> {
        let side = source.size as f32;
        let mut input = Roi::whole(side).sample(source, self.ssd.layout.input);
        if self.signed_input {
            input.iter_mut().for_each(|v| *v = 2.0 * *v - 1.0);
        }
        let (boxes, logits) = self.run(&input)?;
        let mut found: Vec<Detection> = Vec::new();
        for &min_score in scores {
            for d in self.decode(&boxes, &logits, min_score, max) {
                let new = found.iter().all(|f| iou(f.bounds, d.bounds) <= NMS_OVERLAP);
                if new && found.len() < max {
                    found.push(d);
                }
            }
        }
        Ok(found
            .into_iter()
            .map(|d| Detection {
                score: d.score,
                bounds: d.bounds.map(|b| b * side),
                keypoints: d.keypoints.iter().map(|k| *k * side).collect(),
            })
            .collect())
    }
}

fn iou(a: [Vec2; 2], b: [Vec2; 2]) -> f32 {
    let (lo, hi) = (a[0].max(b[0]), a[1].min(b[1]));
    let area = |r: [Vec2; 2]| (r[1] - r[0]).max(Vec2::ZERO).element_product();
    let inter = area([lo, hi]);
    let union = area(a) + area(b) - inter;
    if union > 0.0 { inter / union } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pose detector's 2,254 anchors and the palm detector's 2,016, in MediaPipe's order.
    #[test]
    fn anchors_match_the_models_outputs() {
        let pose = Ssd::new(SsdLayout {
            input: 224,
            grids: &[(8, 2), (16, 2), (32, 6)],
            keypoints: 4,
        });
        let a = &pose.anchors;
        assert_eq!(a.len(), 2254);
        assert_eq!(a[0], Vec2::splat(0.5 / 28.0));
        assert_eq!(a[1], a[0]);
        assert_eq!(a[28 * 28 * 2], Vec2::splat(0.5 / 14.0));
        assert_eq!(a[a.len() - 1], Vec2::splat(6.5 / 7.0));
        let palm = Ssd::new(SsdLayout {
            input: 192,
            grids: &[(8, 2), (16, 6)],
            keypoints: 7,
        });
        assert_eq!((palm.anchors(), palm.values()), (2016, 18));
    }

    /// Two overlapping boxes make one detection averaged by score; a distant one stays apart.
    #[test]
    fn weighted_suppression_averages_clusters() {
        let ssd = Ssd::new(SsdLayout {
            input: 16,
            grids: &[(8, 1)],
            keypoints: 1,
        });
        // Anchors at (0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75) of a 16² input.
        let mut boxes = vec![0.0; 4 * 6];
        let logit = |p: f32| (p / (1.0 - p)).ln();
        let mut logits = vec![-10.0; 4];
        // Anchor 0 and 1 both claim a 8×8 box near (0.5, 0.25); anchor 3 its own.
        boxes[0..6].copy_from_slice(&[3.0, 0.0, 8.0, 8.0, 0.0, 0.0]);
        boxes[6..12].copy_from_slice(&[-3.0, 0.0, 8.0, 8.0, 0.0, 0.0]);
        boxes[18..24].copy_from_slice(&[0.0, 0.0, 4.0, 4.0, 0.0, 0.0]);
        (logits[0], logits[1], logits[3]) = (logit(0.9), logit(0.6), logit(0.7));
        let found = ssd.decode(&boxes, &logits, 0.5, 4);
        assert_eq!(found.len(), 2);
        assert!((found[0].score - 0.9).abs() < 1e-5 && (found[1].score - 0.7).abs() < 1e-5);
        // Centres 0.25 + 3/16 and 0.75 − 3/16, weighted 0.9 : 0.6.
        let x = (0.9 * (0.25 + 3.0 / 16.0) + 0.6 * (0.75 - 3.0 / 16.0)) / 1.5;
        let centre = 0.5 * (found[0].bounds[0] + found[0].bounds[1]);
        assert!((centre - Vec2::new(x, 0.25)).length() < 1e-5, "{centre}");
        assert!((found[0].keypoints[0].x - (0.9 * 0.25 + 0.6 * 0.75) / 1.5).abs() < 1e-5);
        assert_eq!(ssd.decode(&boxes, &logits, 0.5, 1).len(), 1);
    }
}
