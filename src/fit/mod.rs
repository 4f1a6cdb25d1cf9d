//! Single-image fitting: the camera and body pose of the default body that put its landmarks on
//! a photo's 2D keypoints (Levenberg–Marquardt with a pose prior, in Rust).
//!
//! Unknowns: the global orientation (root axis-angle), the camera translation (GUAVA's camera:
//! `invtanfov` 24, looking at the body's front, so its distance sets the scale), the rotations
//! of [`FITTED_JOINTS`] and the shape coefficients (kept within their ranges). Residuals: each
//! keypoint's reprojection error in pixels, weighted by √confidence; the priors pull joint
//! rotations to rest at [`PRIOR_PX_PER_RAD`] pixels per radian, so joints no keypoint
//! constrains (legs out of frame, twist about a bone) stay near rest, and shape to the default
//! at [`SHAPE_PRIOR_PX`] per unit. Expression is not fitted (no face keypoints yet).

use glam::{Mat4, Vec2, Vec3, Vec4};

use crate::body::{BodyModel, BodyPose, PosedBody};
use crate::camera::{Camera, GUAVA_INVTANFOV};
use crate::keypoints::Keypoint;
use crate::reconstruct::SourceView;

/// The joints the fit turns (besides the root).
pub const FITTED_JOINTS: [&str; 11] = [
    "spine03",
    "neck01",
    "head",
    "upperarm01.L",
    "upperarm01.R",
    "lowerarm01.L",
    "lowerarm01.R",
    "upperleg01.L",
    "upperleg01.R",
    "lowerleg01.L",
    "lowerleg01.R",
];
/// Prior strength: a joint turned by 1 rad costs as much as a keypoint 25 px off.
pub const PRIOR_PX_PER_RAD: f64 = 25.0;
/// Shape prior: a shape coefficient at 1 (a phenotype's end) costs as much as a keypoint 20 px off.
pub const SHAPE_PRIOR_PX: f64 = 20.0;
/// The global orientation's prior is weaker: people face the camera at any angle.
const ROOT_PRIOR_PX_PER_RAD: f64 = 2.0;
/// Keypoints the model is less sure of are left out.
pub const MIN_CONFIDENCE: f32 = 0.5;
const ITERATIONS: usize = 30;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FitError {
    #[error(
        "only {found} confident body keypoints ({names}); the fit needs both shoulders and at least 4 in all"
    )]
    TooFewKeypoints { found: usize, names: String },
    #[error("the body has no landmark or joint named {0:?}")]
    MissingOnBody(String),
}

#[derive(Clone, Debug, PartialEq)]
pub struct FitReport {
    pub keypoints_used: usize,
    pub iterations: usize,
    /// Root-mean-square reprojection error of the used keypoints, in pixels.
    pub rms_px: f32,
}

/// The camera looking at the body's front (+z) from +z: x right on the body's left, y down.
fn camera_for(translation: Vec3, side: u32) -> Camera {
    let flip = Mat4::from_diagonal(Vec4::new(1.0, -1.0, -1.0, 1.0));
    Camera::guava(
        Mat4::from_translation(translation) * flip,
        side,
        GUAVA_INVTANFOV,
    )
}

struct Problem<'a> {
    body: &'a BodyModel,
    side: u32,
    /// (landmark index, observed pixel, √confidence)
    observations: Vec<(usize, Vec2, f64)>,
    joints: Vec<usize>,
    /// Shape targets and their ranges.
    shapes: Vec<(usize, [f32; 2])>,
    posed: PosedBody,
}

impl Problem<'_> {
    fn view(&self, p: &[f64]) -> SourceView {
        let mut pose = BodyPose::rest(self.body);
        let v = |i: usize| Vec3::new(p[i] as f32, p[i + 1] as f32, p[i + 2] as f32);
        pose.rotations[0] = v(0);
        for (k, &j) in self.joints.iter().enumerate() {
            pose.rotations[j] = v(6 + 3 * k);
        }
        let first_shape = 6 + 3 * self.joints.len();
        for (k, &(t, [lo, hi])) in self.shapes.iter().enumerate() {
            pose.coefficients[t] = (p[first_shape + k] as f32).clamp(lo, hi);
        }
        SourceView {
            pose,
            camera: camera_for(v(3), self.side),
        }
    }

    fn residuals(&mut self, p: &[f64], out: &mut Vec<f64>) {
        out.clear();
        let view = self.view(p);
        if self.body.pose(&view.pose, &mut self.posed).is_err() {
            out.resize(self.len(), 1e6);
            return;
        }
        for &(l, observed, w) in &self.observations {
            let lm = &self.body.landmarks[l];
            let x: Vec3 = lm
                .vertices
                .iter()
                .zip(&lm.weights)
                .map(|(&v, &wt)| wt * self.posed.vertices[v as usize])
                .sum();
            let q = view.camera.project(x);
            let ok = q.z > 0.0 && q.is_finite();
            for (a, b) in [(q.x, observed.x), (q.y, observed.y)] {
                out.push(if ok { w * (a - b) as f64 } else { 1e4 });
            }
        }
        let first_shape = 6 + 3 * self.joints.len();
        out.extend(p[..3].iter().map(|x| ROOT_PRIOR_PX_PER_RAD * x));
        out.extend(p[6..first_shape].iter().map(|x| PRIOR_PX_PER_RAD * x));
        out.extend(p[first_shape..].iter().map(|x| SHAPE_PRIOR_PX * x));
    }

    fn len(&self) -> usize {
        2 * self.observations.len() + 3 + 3 * self.joints.len() + self.shapes.len()
    }
}

/// Fits the default body to `keypoints` in a `side`² image (GUAVA's camera) and returns the
/// source view (pose and camera) for reconstruction.
pub fn fit_keypoints(
    body: &BodyModel,
    keypoints: &[Keypoint],
    side: u32,
) -> Result<(SourceView, FitReport), FitError> {
    let landmark = |name: &str| body.landmarks.iter().position(|l| l.name == name);
    let mut observations = Vec::new();
    let mut names = Vec::new();
    for k in keypoints.iter().filter(|k| k.confidence >= MIN_CONFIDENCE) {
        let l = landmark(k.name).ok_or_else(|| FitError::MissingOnBody(k.name.into()))?;
        observations.push((l, k.pixel, (k.confidence as f64).sqrt()));
        names.push(k.name);
    }
    let has = |n: &str| names.contains(&n);
    if observations.len() < 4 || !has("left_shoulder") || !has("right_shoulder") {
        return Err(FitError::TooFewKeypoints {
            found: observations.len(),
            names: names.join(", "),
        });
    }
    let joints = FITTED_JOINTS
        .iter()
        .map(|n| {
            body.joint_index(n)
                .ok_or_else(|| FitError::MissingOnBody((*n).into()))
        })
        .collect::<Result<Vec<_>, _>>()?;

    // Start: rest pose, the camera placing the shoulders' midpoint and width where observed.
    let rest = body.landmark_positions(&body.vertices);
    let (ls, rs) = (landmark("left_shoulder"), landmark("right_shoulder"));
    let (ls, rs) = (ls.expect("checked"), rs.expect("checked"));
    let observed = |l: usize| observations.iter().find(|o| o.0 == l).expect("checked").1;
    let (m3, w3) = (0.5 * (rest[ls] + rest[rs]), rest[ls].distance(rest[rs]));
    let (m2, w2) = (
        0.5 * (observed(ls) + observed(rs)),
        observed(ls).distance(observed(rs)),
    );
    let focal = GUAVA_INVTANFOV * side as f32 / 2.0;
    let depth = focal * w3 / w2.max(1.0);
    let centre = side as f32 / 2.0;
    let t = Vec3::new(
        (m2.x - centre) * depth / focal - m3.x,
        (m2.y - centre) * depth / focal + m3.y,
        depth + m3.z,
    );
    let shapes: Vec<(usize, [f32; 2])> = body
        .targets_in(crate::body::TargetGroup::Shape)
        .map(|(i, t)| (i, t.range))
        .collect();
    let n = 6 + 3 * joints.len() + shapes.len();
    let mut p = vec![0.0f64; n];
    p[3..6].copy_from_slice(&[t.x as f64, t.y as f64, t.z as f64]);

    let mut problem = Problem {
        body,
        side,
        observations,
        joints,
        shapes,
        posed: PosedBody::default(),
    };
    let (mut r, mut r_step) = (Vec::new(), Vec::new());
    problem.residuals(&p, &mut r);
    let mut cost: f64 = r.iter().map(|x| x * x).sum();
    let mut mu = 1e-3;
    let mut jac = vec![0.0f64; r.len() * n];
    let mut iterations = 0;
    for _ in 0..ITERATIONS {
        iterations += 1;
        // Forward-difference Jacobian, column by column.
        for c in 0..n {
            let h = if (3..6).contains(&c) {
                1e-3 * depth as f64 / 10.0
            } else {
                1e-4
            };
            let mut q = p.clone();
            q[c] += h;
            problem.residuals(&q, &mut r_step);
            for (row, (a, b)) in r_step.iter().zip(&r).enumerate() {
                jac[row * n + c] = (a - b) / h;
            }
        }
        let (jtj, jtr) = normal_equations(&jac, &r, n);
        let mut improved = false;
        for _ in 0..10 {
            let mut a = jtj.clone();
            for i in 0..n {
                a[i * n + i] += mu * jtj[i * n + i].max(1e-9);
            }
            let Some(delta) = solve(a, jtr.iter().map(|x| -x).collect(), n) else {
                mu *= 10.0;
                continue;
            };
            let q: Vec<f64> = p.iter().zip(&delta).map(|(a, d)| a + d).collect();
            problem.residuals(&q, &mut r_step);
            let new_cost: f64 = r_step.iter().map(|x| x * x).sum();
            if new_cost < cost {
                let gain = (cost - new_cost) / cost.max(1e-12);
                p = q;
                std::mem::swap(&mut r, &mut r_step);
                cost = new_cost;
                mu = (mu / 3.0).max(1e-9);
                improved = gain > 1e-7;
                break;
            }
            mu *= 4.0;
        }
        if !improved {
            break;
        }
    }
    let observed = problem.observations.len();
    let se: f64 = r[..2 * observed]
        .chunks_exact(2)
        .zip(&problem.observations)
        .map(|(d, o)| (d[0] * d[0] + d[1] * d[1]) / (o.2 * o.2))
        .sum();
    let report = FitReport {
        keypoints_used: observed,
        iterations,
        rms_px: (se / observed as f64).sqrt() as f32,
    };
    Ok((problem.view(&p), report))
}

/// JᵀJ and Jᵀr of a row-major `rows × n` Jacobian.
fn normal_equations(jac: &[f64], r: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut jtj = vec![0.0; n * n];
    let mut jtr = vec![0.0; n];
    for (row, &ri) in jac.chunks_exact(n).zip(r) {
        for i in 0..n {
            if row[i] == 0.0 {
                continue;
            }
            jtr[i] += row[i] * ri;
            for j in 0..n {
                jtj[i * n + j] += row[i] * row[j];
            }
        }
    }
    (jtj, jtr)
}

/// Solves the symmetric positive definite system `a·x = b` by Cholesky; `None` if it is not.
fn solve(mut a: Vec<f64>, mut b: Vec<f64>, n: usize) -> Option<Vec<f64>> {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if d.is_nan() || d <= 0.0 {
            return None;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    for i in 0..n {
        let s: f64 = (0..i).map(|k| a[i * n + k] * b[k]).sum();
        b[i] = (b[i] - s) / a[i * n + i];
    }
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|k| a[k * n + i] * b[k]).sum();
        b[i] = (b[i] - s) / a[i * n + i];
    }
    Some(b)
}
