//! What one stage of the fit minimises (Levenberg–Marquardt, [`super::lm`]): observed pixels of
//! posed body points and joints, with priors on its unknowns (joint rotations, the camera,
//! morph coefficients within their ranges, the face features' image offsets).

use glam::{Mat4, Vec2, Vec3, Vec4};

use super::{FACE_FEATURES, lm};
use crate::body::{BodyModel, BodyPose, PointPoser};
use crate::camera::{Camera, GUAVA_INVTANFOV};

/// The camera looking at the body's front (+z) from +z: x right on the body's left, y down.
pub fn camera_for(translation: Vec3, side: u32) -> Camera {
    let flip = Mat4::from_diagonal(Vec4::new(1.0, -1.0, -1.0, 1.0));
    Camera::guava(
        Mat4::from_translation(translation) * flip,
        side,
        GUAVA_INVTANFOV,
    )
}

/// One scalar the fit moves.
#[derive(Clone, Copy)]
pub(super) enum Unknown {
    /// The camera translation's component.
    Camera(usize),
    /// A joint rotation's axis-angle component.
    Joint(usize, usize),
    /// A morph target's coefficient, clamped to its range.
    Coefficient(usize, [f32; 2]),
    /// A face feature's image offset component (face stage only).
    FeatureOffset(usize, usize),
}

/// What an observed pixel is of: a posed point of the poser, or a joint.
#[derive(Clone, Copy)]
pub(super) enum Target {
    Point(usize),
    Joint(usize),
}

/// A pose and camera as the fit holds them, with the face's feature offsets: where a fit ended,
/// for the next frame of a video to start from ([`super::fit_frame`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FitState {
    pub pose: BodyPose,
    /// The camera's translation; its rotation is [`camera_for`]'s, facing the body's front.
    pub camera: Vec3,
    /// How far each of the person's facial features sits from the default face's, in pixels
    /// of the fitted image (identity: fitted on a photo or a video's first frame, then kept).
    pub feature_offsets: [Vec2; FACE_FEATURES.len()],
}

impl FitState {
    /// The state a source view holds (its pose and camera), with no feature offsets.
    pub fn of_view(view: &crate::tracking::SourceView) -> Self {
        Self {
            pose: view.pose.clone(),
            camera: view.camera.view_from_world.w_axis.truncate(),
            feature_offsets: [Vec2::ZERO; FACE_FEATURES.len()],
        }
    }

    /// GUAVA's camera of this state for a `side`² image.
    pub fn camera(&self, side: u32) -> Camera {
        camera_for(self.camera, side)
    }

    pub(super) fn get(&self, u: Unknown) -> f64 {
        match u {
            Unknown::Camera(k) => self.camera[k] as f64,
            Unknown::Joint(j, k) => self.pose.rotations[j][k] as f64,
            Unknown::Coefficient(t, _) => self.pose.coefficients[t] as f64,
            Unknown::FeatureOffset(g, k) => self.feature_offsets[g][k] as f64,
        }
    }

    pub(super) fn set(&mut self, u: Unknown, value: f64) {
        let v = value as f32;
        match u {
            Unknown::Camera(k) => self.camera[k] = v,
            Unknown::Joint(j, k) => self.pose.rotations[j][k] = v,
            Unknown::Coefficient(t, [lo, hi]) => self.pose.coefficients[t] = v.clamp(lo, hi),
            Unknown::FeatureOffset(g, k) => self.feature_offsets[g][k] = v,
        }
    }
}

/// What one stage minimises: observed pixels of posed points, and priors on its unknowns.
pub(super) struct Stage<'a> {
    pub(super) body: &'a BodyModel,
    pub(super) side: u32,
    pub(super) poser: &'a mut PointPoser,
    /// (what is observed, observed pixel, weight).
    pub(super) observations: Vec<(Target, Vec2, f64)>,
    /// Per observation: the face feature it belongs to, if any.
    pub(super) features: Vec<Option<usize>>,
    /// Scratch: each observation's projected pixel.
    pub(super) pixels: Vec<Vec2>,
    /// Each unknown with its prior weight (pixels per unit away from zero).
    pub(super) unknowns: Vec<(Unknown, f64)>,
    /// Pairs of morph targets that pay `weight · a · b` for acting together.
    pub(super) antagonists: Vec<(usize, usize, f64)>,
    /// Per unknown, where the last frame of a video had it and how strongly it is pulled there
    /// (pixels per unit); empty for a photo.
    pub(super) temporal: Vec<(f64, f64)>,
    /// Levenberg–Marquardt iterations at most.
    pub(super) iterations: usize,
    pub(super) base: FitState,
    /// Where the priors pull joints: rest, or a relaxed hang for a T-posed rig's arms.
    pub(super) relaxed: BodyPose,
    pub(super) points: Vec<Vec3>,
    pub(super) joints: Vec<Vec3>,
}

impl Stage<'_> {
    pub(super) fn state(&self, p: &[f64]) -> FitState {
        let mut s = self.base.clone();
        for (&(u, _), &v) in self.unknowns.iter().zip(p) {
            s.set(u, v);
        }
        s
    }

    pub(super) fn residuals(&mut self, p: &[f64], out: &mut Vec<f64>) {
        out.clear();
        let s = self.state(p);
        let posed = self
            .poser
            .pose(self.body, &s.pose, &mut self.points, &mut self.joints);
        let camera = camera_for(s.camera, self.side);
        let mut ok = posed.is_ok();
        self.pixels.clear();
        for &(target, _, _) in &self.observations {
            let x = match target {
                Target::Point(i) => self.points[i],
                Target::Joint(j) => self.joints[j],
            };
            let q = camera.project(x);
            ok &= q.z > 0.0 && q.is_finite();
            self.pixels.push(Vec2::new(q.x, q.y));
        }
        for (q, &feature) in self.pixels.iter_mut().zip(&self.features) {
            if let Some(g) = feature {
                *q += s.feature_offsets[g];
            }
        }
        for (q, &(_, observed, w)) in self.pixels.iter().zip(&self.observations) {
            for (a, b) in [(q.x, observed.x), (q.y, observed.y)] {
                out.push(if ok { w * (a - b) as f64 } else { 1e4 });
            }
        }
        out.extend(self.unknowns.iter().zip(p).map(|(&(u, w), &v)| {
            let centre = match u {
                Unknown::Joint(j, k) => self.relaxed.rotations[j][k] as f64,
                _ => 0.0,
            };
            w * (v - centre)
        }));
        out.extend(
            self.temporal
                .iter()
                .zip(p)
                .map(|(&(previous, w), &v)| w * (v - previous)),
        );
        let c = &s.pose.coefficients;
        out.extend(
            self.antagonists
                .iter()
                .map(|&(a, b, w)| w * (c[a] * c[b]) as f64),
        );
    }

    /// Minimises from `self.base`; returns the state, the iterations taken and the final cost.
    pub(super) fn solve(&mut self, camera_step: f64) -> (FitState, usize, f64) {
        let p0: Vec<f64> = self
            .unknowns
            .iter()
            .map(|&(u, _)| self.base.get(u))
            .collect();
        let steps: Vec<f64> = self
            .unknowns
            .iter()
            .map(|(u, _)| match u {
                Unknown::Camera(_) => camera_step,
                Unknown::FeatureOffset(..) => 1e-2,
                _ => 1e-4,
            })
            .collect();
        let solution = lm::minimise(p0, &steps, self.iterations, |p, r| self.residuals(p, r));
        (
            self.state(&solution.params),
            solution.iterations,
            solution.cost,
        )
    }

    /// Where `state` puts the observed points of `range`, in pixels (face points with their
    /// feature offsets).
    pub(super) fn projected(
        &mut self,
        state: &FitState,
        range: std::ops::Range<usize>,
    ) -> Vec<Vec2> {
        let saved = std::mem::replace(&mut self.base, state.clone());
        let mut r = Vec::new();
        self.residuals(&[], &mut r);
        self.base = saved;
        self.pixels[range].to_vec()
    }

    /// Unweighted RMS pixel error of the observations in `state`.
    pub(super) fn rms(&mut self, state: &FitState, range: std::ops::Range<usize>) -> f32 {
        let n = range.len().max(1) as f32;
        let se: f32 = self
            .projected(state, range.clone())
            .iter()
            .zip(&self.observations[range])
            .map(|(p, o)| p.distance_squared(o.1))
            .sum();
        (se / n).sqrt()
    }
}
