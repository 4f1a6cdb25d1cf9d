//! One frame's parameters from its detections: the points through One Euro filters (each
//! model's points scaled by the size of what it found), the fit started from the last frame
//! ([`fit_frame`]), and its output filtered (the joints' rotations as quaternions, the face
//! units as values). The next frame's fit starts from this frame's fit, not from its filtered
//! output, so the filters add no lag to the fit itself. What places the body as a whole, the
//! root's rotation and the camera, is left as the fit of the filtered points gives it: the fit
//! trades the one against the other from frame to frame, and filtering them apart let each lag
//! the other, so a moving head was drawn beside itself (the shipped clip's self-reenactment,
//! `guava eval --video`, 16.31 → 16.67 dB, while the joints' jitter on `guava bench track`'s
//! synthetic wave stays at 30°; the rest unfiltered too gains no more and jitters 56°).

use glam::Vec2;

use super::filter::{OneEuro, OneEuroSettings, RotationFilter};
use crate::body::BodyModel;
use crate::fit::{FaceEmbedding, FitInput, FitState, body_keypoints, fit_frame};
use crate::keypoints::{Detections, Side};

/// A frame rate at which the fit's temporal prior has its nominal strength; slower videos
/// move more between frames and are pulled less.
const NOMINAL_FPS: f64 = 30.0;
/// The body points' confidences through a low-pass of this factor a frame (MediaPipe's
/// visibility smoothing): a point the model is unsure of fades in and out over a few frames.
const CONFIDENCE_ALPHA: f32 = 0.1;

/// Filters for the points of one model, keyed by what they belong to.
struct PointFilter(OneEuro);

impl PointFilter {
    fn new() -> Self {
        Self(OneEuro::new(OneEuroSettings::LANDMARKS))
    }

    /// Filters `points` in place, speeds in sizes of their bounding box a second.
    fn apply(&mut self, time: f64, points: &mut [Vec2]) {
        let (lo, hi) = points.iter().fold((Vec2::MAX, Vec2::MIN), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
        let size = f64::from(((hi - lo).x + (hi - lo).y) / 2.0).max(1.0);
        let mut values: Vec<f64> = points
            .iter()
            .flat_map(|p| [f64::from(p.x), f64::from(p.y)])
            .collect();
        self.0.apply(time, 1.0 / size, &mut values);
        for (p, v) in points.iter_mut().zip(values.chunks_exact(2)) {
            *p = Vec2::new(v[0] as f32, v[1] as f32);
        }
    }
}

/// The fit of a video, frame after frame, with or without filters.
pub struct Solver {
    filtered: bool,
    body_points: PointFilter,
    face_points: PointFilter,
    hand_points: [PointFilter; 2],
    iris_points: PointFilter,
    /// The body points' smoothed confidences (empty until the first frame).
    confidences: Vec<f32>,
    /// The rotations of the joints below the root.
    rotations: RotationFilter,
    coefficients: OneEuro,
    /// The last frame's fit (unfiltered): where the next one starts.
    state: FitState,
    /// The clip's first fit: where the torso's turn is held.
    anchor: FitState,
    /// The last output (filtered when filtering), held when a frame cannot be fitted.
    output: FitState,
}

impl Solver {
    /// A solver continuing from the first frame's fit `start`.
    pub fn new(start: FitState, filtered: bool) -> Self {
        Self {
            filtered,
            body_points: PointFilter::new(),
            face_points: PointFilter::new(),
            hand_points: [PointFilter::new(), PointFilter::new()],
            iris_points: PointFilter::new(),
            confidences: Vec::new(),
            rotations: RotationFilter::new(OneEuroSettings::ROTATIONS),
            coefficients: OneEuro::new(OneEuroSettings::EXPRESSIONS),
            output: start.clone(),
            anchor: start.clone(),
            state: start,
        }
    }

    pub fn is_filtered(&self) -> bool {
        self.filtered
    }

    /// The first frame's points and parameters prime the filters (they pass unchanged).
    pub fn prime(&mut self, detections: &Detections, time: f64) {
        if self.filtered {
            self.filter_points(&mut detections.clone(), time);
            self.filter_output(&mut self.state.clone(), time);
        }
    }

    /// Fits a frame at `time` seconds of a `fps` video; `None` when it cannot be fitted (too
    /// few body points: the person left or is hidden), and the last output stays.
    pub fn solve(
        &mut self,
        body: &BodyModel,
        embedding: Option<&FaceEmbedding>,
        detections: &Detections,
        side: u32,
        time: f64,
        fps: f64,
    ) -> Option<&FitState> {
        let mut found = detections.clone();
        if self.filtered {
            self.filter_points(&mut found, time);
        }
        // The pose model's points, or the head and shoulders from the face where it sees no
        // person (a face close up), as a photo's fit takes them.
        let Ok((keypoints, _)) = body_keypoints(body, &found, side) else {
            self.reset_filters();
            return None;
        };
        let input = FitInput {
            keypoints: &keypoints,
            face: found.face.as_ref().zip(embedding),
            hands: &found.hands,
            irises: &found.irises,
        };
        let temporal = (fps / NOMINAL_FPS).clamp(0.2, 2.0);
        match fit_frame(body, &input, side, &self.state, &self.anchor, temporal) {
            Ok((state, _)) => {
                let mut output = state.clone();
                if self.filtered {
                    self.filter_output(&mut output, time);
                }
                (self.state, self.output) = (state, output);
                Some(&self.output)
            }
            Err(_) => {
                // Whoever comes back is filtered afresh.
                self.reset_filters();
                None
            }
        }
    }

    /// The last output.
    pub fn output(&self) -> &FitState {
        &self.output
    }

    fn reset_filters(&mut self) {
        for f in [
            &mut self.body_points,
            &mut self.face_points,
            &mut self.iris_points,
        ] {
            f.0.reset();
        }
        for f in &mut self.hand_points {
            f.0.reset();
        }
        self.confidences.clear();
        self.rotations.reset();
        self.coefficients.reset();
    }

    fn filter_points(&mut self, found: &mut Detections, time: f64) {
        let mut body: Vec<Vec2> = found.pose.keypoints.iter().map(|k| k.pixel).collect();
        self.body_points.apply(time, &mut body);
        for (k, p) in found.pose.keypoints.iter_mut().zip(body) {
            k.pixel = p;
        }
        if self.confidences.len() != found.pose.keypoints.len() {
            self.confidences = found.pose.keypoints.iter().map(|k| k.confidence).collect();
        }
        for (k, c) in found.pose.keypoints.iter_mut().zip(&mut self.confidences) {
            *c += CONFIDENCE_ALPHA * (k.confidence - *c);
            k.confidence = *c;
        }
        match &mut found.face {
            Some(face) => self.face_points.apply(time, &mut face.points),
            None => self.face_points.0.reset(),
        }
        for (k, side) in [Side::Left, Side::Right].into_iter().enumerate() {
            match found.hands.iter_mut().find(|h| h.side == side) {
                Some(hand) => self.hand_points[k].apply(time, &mut hand.points),
                None => self.hand_points[k].0.reset(),
            }
        }
        // Both irises or none: one filter over their centres, sized by the face.
        if found.irises.len() == 2 {
            let mut centres: Vec<Vec2> = found.irises.iter().map(|i| i.centre).collect();
            self.iris_points.apply(time, &mut centres);
            for (i, c) in found.irises.iter_mut().zip(centres) {
                i.centre = c;
            }
        } else {
            self.iris_points.0.reset();
        }
    }

    fn filter_output(&mut self, state: &mut FitState, time: f64) {
        // Joint 0 is the root: a body's skin lists every other joint after its parent.
        if let Some(below_root) = state.pose.rotations.get_mut(1..) {
            self.rotations.apply(time, below_root);
        }
        let mut values: Vec<f64> = state
            .pose
            .coefficients
            .iter()
            .map(|&c| f64::from(c))
            .collect();
        self.coefficients.apply(time, 1.0, &mut values);
        for (c, v) in state.pose.coefficients.iter_mut().zip(values) {
            *c = v as f32;
        }
    }
}
