//! EHM as one linear-blend-skinned [`BodyModel`], so the single-image fit (written against
//! template bodies) fits GUAVA's body too.
//!
//! At zero rotation EHM's forward is affine in its coefficients (shape and expression blends, the
//! head swapped in and shifted to the body's eyes, hands scaled, joints regressed from the
//! result), so the rest mesh, the rest joints and each coefficient's vertex and joint deltas
//! are read off the forward pass itself: at zero, and at one for each coefficient kept. Posing
//! differs from [`EhmModel::forward`] in three ways, all small: pose correctives are left out;
//! FLAME's jaw and eyes, which EHM turns before the body's skinning, become child joints of the
//! head that share each vertex's head weight (exact for a vertex skinned to the head alone, or
//! not moved by jaw or eyes; a chin vertex also on the neck is approximated); and the eyelid
//! shapes, which EHM adds after FLAME's jaw and eyes turn, come before (the same for lids that
//! do not follow the eyeballs, as FLAME's do not). The joints keep
//! SMPL-X's order, named as on the default rig where it has the joint ([`smplx_to_default`]), so
//! a pose of the linear body is a pose of EHM ([`EhmModel::pose_from_linear`]).

use glam::{Vec2, Vec3};

use super::{EhmExtras, EhmModel, EhmParams, FLAME_EYES, FLAME_JAW, SMPLX_EYES, SMPLX_JAW};
use crate::body::coco_limb_keypoints;
use crate::body::{
    BodyModel, BodyPose, Joint, Landmark, MAX_INFLUENCES, MorphTarget, Posable, PoseError,
    PosedBody, SMPLX_JOINTS, TargetGroup, smplx_to_default,
};

/// The leading PCA components the linear body carries for fitting, of SMPL-X shape, FLAME shape
/// and FLAME expression: what 2D keypoints can tell apart (later components stay zero).
pub const LINEAR_COMPONENTS: usize = 10;
/// PCA coefficients are in standard deviations; the fit keeps them within ±3.
const PCA_RANGE: [f32; 2] = [-3.0, 3.0];
const SMPLX_HEAD: usize = 15;
/// Ears are the head's outermost points within this height of the eyes (metres), if it has any.
const EAR_BAND: f32 = 0.03;
const REST_FITS: &str = "a pose made by BodyPose::rest of the model has its lengths";
/// An eyeball's vertices within this fraction of its radius from its front are its iris.
const IRIS_DEPTH: f32 = 0.4;

impl EhmModel {
    /// The linear body (see the module doc), with this model's identity.
    pub fn linearised(&self) -> BodyModel {
        let base = self.rest_parts(
            &self
                .params_from_pose(&BodyPose::rest(self))
                .expect(REST_FITS),
        );
        let n = base.vertices.len();

        let names: Vec<&str> = self.parameter_names().collect();
        let kept = |prefix: &'static str, group, range| {
            (0..LINEAR_COMPONENTS).map(move |i| (format!("{prefix}{i:03}"), group, range))
        };
        let wanted = kept("shape_", TargetGroup::Shape, PCA_RANGE)
            .chain(kept("flame_shape_", TargetGroup::Shape, PCA_RANGE))
            .chain(kept(
                "flame_expression_",
                TargetGroup::Expression,
                PCA_RANGE,
            ))
            .chain(
                ["eyelid_left", "eyelid_right"]
                    .map(|e| (e.into(), TargetGroup::Expression, [0.0, 1.0])),
            );
        let mut targets = Vec::new();
        for (name, group, range) in wanted {
            let Some(i) = names.iter().position(|n| *n == name) else {
                continue;
            };
            let mut unit = BodyPose::rest(self);
            unit.coefficients[i] = 1.0;
            let moved = self.rest_parts(&self.params_from_pose(&unit).expect(REST_FITS));
            let (vertices, deltas) = (0..n)
                .map(|v| (v as u32, moved.vertices[v] - base.vertices[v]))
                .filter(|(_, d)| *d != Vec3::ZERO)
                .unzip();
            targets.push(MorphTarget {
                name,
                group,
                range,
                vertices,
                deltas,
                joint_deltas: moved
                    .joints
                    .iter()
                    .zip(&base.joints)
                    .map(|(a, b)| *a - *b)
                    .collect(),
            });
        }

        let joints = SMPLX_JOINTS
            .iter()
            .enumerate()
            .map(|(j, name)| Joint {
                name: smplx_to_default(name).unwrap_or_else(|| (*name).into()),
                parent: self.body.parents[j],
                rest: base.joints[j],
            })
            .collect();
        let (skin_joints, skin_weights) = self.linear_skin();
        let mut uvs = vec![Vec2::ZERO; n];
        for (t, corners) in self.triangles.iter().zip(&self.triangle_uvs) {
            for (&v, &c) in t.iter().zip(corners) {
                uvs[v as usize] = self.texcoords[c as usize];
            }
        }
        let mut body = BodyModel {
            name: format!("{} (linearised for fitting)", self.name),
            vertices: base.vertices,
            uvs,
            triangles: self.triangles.clone(),
            weld: (0..n as u32).collect(),
            joints,
            skin_joints,
            skin_weights,
            targets,
            landmarks: Vec::new(),
            part_names: Vec::new(),
            vertex_parts: Vec::new(),
        };
        body.landmarks = self.keypoint_landmarks(&body);
        label_eyes(&mut body);
        body
    }

    /// An EHM pose from a pose of [`EhmModel::linearised`]: the same rotations, coefficients by
    /// name (those the linear body lacks stay zero).
    pub fn pose_from_linear(
        &self,
        linear: &BodyModel,
        pose: &BodyPose,
    ) -> Result<BodyPose, PoseError> {
        pose.check_lengths(linear.joints.len(), linear.targets.len())?;
        let mut out = BodyPose::rest(self);
        out.translation = pose.translation;
        out.rotations.clone_from(&pose.rotations);
        for (t, &c) in linear.targets.iter().zip(&pose.coefficients) {
            out.set_coefficient(self, &t.name, c)?;
        }
        Ok(out)
    }

    /// Rest vertices and joints for `p` (rotations ignored): the body's 55 joints, with FLAME's
    /// jaw and eyes in place of SMPL-X's (which EHM never turns).
    fn rest_parts(&self, p: &EhmParams) -> RestParts {
        let mut posed = PosedBody::default();
        let mut extras = EhmExtras::default();
        self.forward(p, &mut posed, &mut extras);
        let mut joints = posed.rest_joints;
        joints[SMPLX_JAW] = extras.head_joints[FLAME_JAW];
        for (&b, &f) in SMPLX_EYES.iter().zip(&FLAME_EYES) {
            joints[b] = extras.head_joints[f];
        }
        RestParts {
            vertices: posed.vertices,
            joints,
        }
    }

    /// Each vertex's skin: the body's weights with SMPL-X's jaw and eyes folded into the head
    /// (EHM never turns them), and a head vertex's head weight shared out by FLAME's weights
    /// between the head (FLAME's global and neck, never turned) and the jaw and eyes. At most
    /// [`MAX_INFLUENCES`], the largest kept and renormalised.
    #[allow(clippy::type_complexity)]
    fn linear_skin(&self) -> (Vec<[u16; MAX_INFLUENCES]>, Vec<[f32; MAX_INFLUENCES]>) {
        let mut flame = vec![None; self.body.template.len()];
        for (i, &b) in self.head_vertices.iter().enumerate() {
            flame[b as usize] = Some(i);
        }
        let flame_to_body = |f: usize| match f {
            FLAME_JAW => SMPLX_JAW,
            f if f == FLAME_EYES[0] => SMPLX_EYES[0],
            f if f == FLAME_EYES[1] => SMPLX_EYES[1],
            _ => SMPLX_HEAD,
        };
        let mut joints = Vec::with_capacity(flame.len());
        let mut weights = Vec::with_capacity(flame.len());
        for (v, body) in self.body.weights.iter().enumerate() {
            let mut w = [0.0f32; SMPLX_JOINTS.len()];
            for &(j, s) in body {
                let j = j as usize;
                let folded = if j == SMPLX_JAW || SMPLX_EYES.contains(&j) {
                    SMPLX_HEAD
                } else {
                    j
                };
                w[folded] += s;
            }
            if let Some(i) = flame[v] {
                let head = std::mem::take(&mut w[SMPLX_HEAD]);
                for &(f, t) in &self.head.weights[i] {
                    w[flame_to_body(f as usize)] += head * t;
                }
            }
            let mut order: Vec<usize> = (0..w.len()).filter(|&j| w[j] > 0.0).collect();
            order.sort_by(|&a, &b| w[b].total_cmp(&w[a]));
            order.truncate(MAX_INFLUENCES);
            let total: f32 = order.iter().map(|&j| w[j]).sum();
            let (mut js, mut ws) = ([0u16; MAX_INFLUENCES], [0.0f32; MAX_INFLUENCES]);
            for (k, &j) in order.iter().enumerate() {
                js[k] = j as u16;
                ws[k] = w[j] / total.max(f32::MIN_POSITIVE);
            }
            joints.push(js);
            weights.push(ws);
        }
        (joints, weights)
    }

    /// The pose model's COCO keypoints on the body: the limb joints by SMPL-X's regressor (its
    /// vertices, skinned, follow the joint), the eyes by FLAME's eye regressor (the eyeballs'
    /// centres), the nose at the head's foremost vertex and the ears at its outermost vertices
    /// level with the eyes.
    fn keypoint_landmarks(&self, body: &BodyModel) -> Vec<Landmark> {
        let regressed = |name: &str, row: Vec<(u32, f32)>| Landmark {
            name: name.into(),
            vertices: row.iter().map(|&(v, _)| v).collect(),
            weights: row.iter().map(|&(_, w)| w).collect(),
        };
        let mut out: Vec<Landmark> = coco_limb_keypoints()
            .filter_map(|name| {
                let j = SMPLX_JOINTS.iter().position(|n| *n == name)?;
                Some(regressed(name, self.body.regressor[j].clone()))
            })
            .collect();
        for (name, f) in [("left_eye", FLAME_EYES[0]), ("right_eye", FLAME_EYES[1])] {
            let row = self.head.regressor[f]
                .iter()
                .map(|&(v, w)| (self.head_vertices[v as usize], w))
                .collect();
            out.push(regressed(name, row));
        }
        let head = || self.head_vertices.iter().map(|&v| v as usize);
        let at = |v: usize| body.vertices[v];
        let vertex = |name: &str, v: Option<usize>| {
            v.map(|v| Landmark {
                name: name.into(),
                vertices: vec![v as u32],
                weights: vec![1.0],
            })
        };
        let eye_height =
            0.5 * (body.joints[SMPLX_EYES[0]].rest.y + body.joints[SMPLX_EYES[1]].rest.y);
        let level = |v: &usize| (at(*v).y - eye_height).abs() < EAR_BAND;
        let by =
            |key: fn(Vec3) -> f32| move |a: &usize, b: &usize| key(at(*a)).total_cmp(&key(at(*b)));
        // Level with the eyes if the head has vertices there, else anywhere on it.
        let ear = |outermost: fn(Vec3) -> f32| {
            let level_with_eyes = head().filter(level).max_by(by(outermost));
            level_with_eyes.or_else(|| head().max_by(by(outermost)))
        };
        out.extend(vertex("nose", head().max_by(by(|p| p.z))));
        out.extend(vertex("left_ear", ear(|p| p.x)));
        out.extend(vertex("right_ear", ear(|p| -p.x)));
        out
    }
}

struct RestParts {
    vertices: Vec<Vec3>,
    joints: Vec<Vec3>,
}

/// Part labels for the eyeballs (vertices skinned mostly to an eye joint), split into the iris
/// at the front and the white behind, named as on the default body: the face embedding keeps its
/// points off them, the calibration render draws them as eyes and the gaze fit finds the pupils.
fn label_eyes(body: &mut BodyModel) {
    let mut names = vec!["skin".to_string()];
    let mut parts = vec![0u8; body.vertices.len()];
    for (side, eye) in [("L", SMPLX_EYES[0]), ("R", SMPLX_EYES[1])] {
        let ball: Vec<usize> = (0..body.vertices.len())
            .filter(|&v| body.skin_joints[v][0] as usize == eye && body.skin_weights[v][0] > 0.5)
            .collect();
        let Some(front) = ball.iter().map(|&v| body.vertices[v].z).reduce(f32::max) else {
            continue;
        };
        let centre = body.joints[eye].rest;
        let radius = front - centre.z;
        names.push(format!("eye_back.{side}"));
        names.push(format!("eye_front.{side}"));
        let (back_part, front_part) = ((names.len() - 2) as u8, (names.len() - 1) as u8);
        for v in ball {
            let iris = front - body.vertices[v].z < IRIS_DEPTH * radius;
            parts[v] = if iris { front_part } else { back_part };
        }
    }
    if names.len() > 1 {
        body.part_names = names;
        body.vertex_parts = parts;
    }
}
