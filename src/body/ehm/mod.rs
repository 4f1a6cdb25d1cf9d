//! EHM, GUAVA's body: SMPL-X with its head replaced by FLAME (reference
//! `models/modules/ehm/EHM.py:EHM.forward`, digested in notes/guava-pipeline.md §3.4).
//!
//! The model comes from the user's registration-only SMPL-X and FLAME files through
//! `tools/convert_ehm.py` (the reference constructor builds it, teeth included); [`EhmModel::load`]
//! reads and validates that file. [`EhmModel::forward`] follows the reference step by step in f32;
//! `tests/ehm.rs` checks it against the reference on a synthetic model to 1e-5 m.

mod file;
mod linear;

use glam::{Affine3A, Mat3A, Vec3};

use super::lbs::{blend, rigid_chain, rodrigues};
use super::pose::finite_or_zero;
use super::{BodyPose, Posable, PoseError, PosedBody, SMPLX_JOINTS};

pub use file::EHM_FORMAT;
pub use linear::LINEAR_COMPONENTS;

/// SMPL-X joint layout: root, 21 body joints, jaw, two eyes, then 15 joints per hand.
const SMPLX_BODY: usize = 1;
const BODY_JOINTS: usize = 21;
const SMPLX_LEFT_HAND: usize = 25;
const SMPLX_RIGHT_HAND: usize = 40;
const HAND_JOINTS: usize = 15;
/// SMPL-X joints whose rotations EHM takes from the FLAME head instead (always zero on the body).
const SMPLX_JAW: usize = 22;
const SMPLX_EYES: [usize; 2] = [23, 24];
/// FLAME joints: global, neck, jaw, left eye, right eye.
const FLAME_JAW: usize = 2;
const FLAME_EYES: [usize; 2] = [3, 4];

/// One skinned mesh of EHM (the SMPL-X body or the FLAME head), laid out for posing.
#[derive(Clone, Debug)]
pub struct Skinned {
    pub template: Vec<Vec3>,
    /// Shape then expression directions, component-major: `dirs[c][3·v + axis]`.
    pub shape_dirs: Vec<Vec<f32>>,
    /// Pose correctives, row per (non-root joint, 3×3 entry): `pose_dirs[9·(j−1) + 3·row + col]`.
    pub pose_dirs: Vec<Vec<f32>>,
    /// Sparse joint regressor: per joint, (vertex, weight).
    pub regressor: Vec<Vec<(u32, f32)>>,
    pub parents: Vec<Option<usize>>,
    /// Sparse skin weights: per vertex, (joint, weight).
    pub weights: Vec<Vec<(u16, f32)>>,
}

/// GUAVA's texel → triangle map (`SMPLX.uvmap_f_idx`, `uvmap_f_bary`) as its start-up
/// rasterizes it with OpenCV: `size`² texels row-major, triangle −1 where empty.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceTexels {
    pub size: u32,
    pub triangle: Vec<i32>,
    pub bary: Vec<[f32; 3]>,
}

/// The converted EHM (see `tools/convert_ehm.py` for the file layout).
#[derive(Clone, Debug)]
pub struct EhmModel {
    pub name: String,
    pub n_shape: usize,
    pub n_exp: usize,
    pub body: Skinned,
    pub head: Skinned,
    pub triangles: Vec<[u32; 3]>,
    /// Per-corner texture coordinates (index into `texcoords`), v already flipped as the reference.
    pub triangle_uvs: Vec<[u32; 3]>,
    pub texcoords: Vec<glam::Vec2>,
    /// FLAME vertex i is body vertex `head_vertices[i]` (teeth included).
    pub head_vertices: Vec<u32>,
    pub hands: [Vec<u32>; 2],
    pub hand_centres: [Vec3; 2],
    /// FLAME eyelid blendshapes, left then right.
    pub eyelids: [Vec<Vec3>; 2],
    /// Per-avatar identity used by [`Posable::pose`] (the tracker's `id_share_params`).
    pub identity: EhmIdentity,
    /// The reference's own UV texel map, when the converter stored it.
    pub reference_texels: Option<ReferenceTexels>,
    parameter_names: Vec<String>,
    shape_caches: ShapeCaches,
}

/// The per-avatar part of the tracking: joint offsets and head/hand scales.
#[derive(Clone, Debug, PartialEq)]
pub struct EhmIdentity {
    pub joints_offset: Vec<Vec3>,
    pub head_scale: Vec3,
    pub hand_scale: Vec3,
}

impl Default for EhmIdentity {
    fn default() -> Self {
        Self {
            joints_offset: vec![Vec3::ZERO; SMPLX_JOINTS.len()],
            head_scale: Vec3::ONE,
            hand_scale: Vec3::ONE,
        }
    }
}

/// EHM parameters in the tracker's layout (`smplx_coeffs` + `flame_coeffs`, notes §2.1).
/// Shape vectors shorter than `n_shape` are zero-padded, as the reference does.
#[derive(Clone, Debug, PartialEq)]
pub struct EhmParams {
    pub shape: Vec<f32>,
    /// SMPL-X expression (enters the body's shape blend).
    pub expression: Vec<f32>,
    pub global_pose: Vec3,
    pub body_pose: Vec<Vec3>,
    pub left_hand_pose: Vec<Vec3>,
    pub right_hand_pose: Vec<Vec3>,
    pub flame_shape: Vec<f32>,
    pub flame_expression: Vec<f32>,
    pub jaw: Vec3,
    /// Left then right eye.
    pub eyes: [Vec3; 2],
    /// Left then right eyelid.
    pub eyelids: [f32; 2],
    pub identity: EhmIdentity,
    /// Added to every posed point (metres). Not part of the reference, where it is always zero.
    pub translation: Vec3,
}

impl EhmParams {
    pub fn rest(model: &EhmModel) -> Self {
        Self {
            shape: vec![0.0; model.n_shape],
            expression: vec![0.0; model.n_exp],
            global_pose: Vec3::ZERO,
            body_pose: vec![Vec3::ZERO; BODY_JOINTS],
            left_hand_pose: vec![Vec3::ZERO; HAND_JOINTS],
            right_hand_pose: vec![Vec3::ZERO; HAND_JOINTS],
            flame_shape: vec![0.0; model.n_shape],
            flame_expression: vec![0.0; model.n_exp],
            jaw: Vec3::ZERO,
            eyes: [Vec3::ZERO; 2],
            eyelids: [0.0; 2],
            identity: EhmIdentity::default(),
            translation: Vec3::ZERO,
        }
    }
}

/// Intermediate results of a forward pass, kept for inspection and tests.
#[derive(Clone, Debug, Default)]
pub struct EhmExtras {
    /// Posed FLAME head before it is placed on the body (after eyelids and head scale).
    pub head_vertices: Vec<Vec3>,
    /// Skinning placements A_j of the body joints (`joint_transform_mat`).
    pub placements: Vec<Affine3A>,
    /// FLAME's five joints (global, neck, jaw, eyes) placed as its head is placed on the body
    /// (scaled, shifted), before the body's own skinning.
    pub head_joints: Vec<Vec3>,
}

/// The identity part of a shape blend (template + shape directions), kept while the shape
/// coefficients stay the same: during playback only expressions change, and the blend is summed
/// in the same order either way, so cached and fresh results are bit-identical.
#[derive(Debug, Default)]
struct ShapeCache {
    key: Vec<f32>,
    shaped: Vec<Vec3>,
}

/// One cache per mesh behind a lock, so posing through `&self` can reuse it.
#[derive(Debug, Default)]
struct ShapeCaches([std::sync::Mutex<ShapeCache>; 2]);

impl Clone for ShapeCaches {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl Skinned {
    /// template + Σ s·shape_dirs + Σ e·expression_dirs (zeros skipped), the shape part cached.
    fn shaped(
        &self,
        shape: &[f32],
        expression: &[f32],
        cache: &std::sync::Mutex<ShapeCache>,
        out: &mut Vec<Vec3>,
    ) {
        let mut cache = cache
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if cache.key != shape || cache.shaped.len() != self.template.len() {
            cache.key = shape.to_vec();
            cache.shaped = self.template.clone();
            let flat: &mut [f32] = bytemuck::cast_slice_mut(cache.shaped.as_mut_slice());
            for (dir, &c) in self.shape_dirs.iter().zip(shape) {
                if c != 0.0 {
                    axpy(c, dir, flat);
                }
            }
        }
        out.clear();
        out.extend_from_slice(&cache.shaped);
        let flat: &mut [f32] = bytemuck::cast_slice_mut(out.as_mut_slice());
        for (dir, &c) in self.shape_dirs[shape.len()..].iter().zip(expression) {
            if c != 0.0 {
                axpy(c, dir, flat);
            }
        }
    }

    fn regress_joint(&self, j: usize, vertices: &[Vec3]) -> Vec3 {
        self.regressor[j]
            .iter()
            .map(|&(v, w)| w * vertices[v as usize])
            .sum()
    }

    fn regress(&self, vertices: &[Vec3]) -> Vec<Vec3> {
        (0..self.regressor.len())
            .map(|j| self.regress_joint(j, vertices))
            .collect()
    }

    /// The reference `lbs_wobeta` on an already shaped template: joints regressed from it (plus
    /// offsets), pose correctives from (R_j − I) of every non-root joint, rigid chain (the root
    /// moved by `translation`), skinning.
    fn skin(
        &self,
        shaped: &[Vec3],
        rotations: &[Mat3A],
        joints_offset: Option<&[Vec3]>,
        translation: Vec3,
        out: &mut PosedBody,
        placements: &mut Vec<Affine3A>,
    ) {
        let mut rest = self.regress(shaped);
        if let Some(offsets) = joints_offset {
            rest.iter_mut().zip(offsets).for_each(|(j, o)| *j += *o);
        }
        out.vertices.clear();
        out.vertices.extend_from_slice(shaped);
        let flat: &mut [f32] = bytemuck::cast_slice_mut(out.vertices.as_mut_slice());
        for (j, r) in rotations.iter().enumerate().skip(1) {
            let feature = *r - Mat3A::IDENTITY;
            for row in 0..3 {
                for col in 0..3 {
                    let c = feature.col(col)[row];
                    if c != 0.0 {
                        axpy(c, &self.pose_dirs[9 * (j - 1) + 3 * row + col], flat);
                    }
                }
            }
        }
        rigid_chain(
            self.parents.iter().copied(),
            &rest,
            rotations,
            translation,
            &mut out.joints,
            placements,
        );
        out.skin.clear();
        for (v, weights) in out.vertices.iter_mut().zip(&self.weights) {
            let skin = blend(weights.iter().map(|&(j, w)| (j as usize, w)), placements);
            *v = skin.transform_point3(*v);
            out.skin.push(skin);
        }
        out.rest_joints = rest;
    }
}

fn axpy(c: f32, x: &[f32], y: &mut [f32]) {
    for (y, x) in y.iter_mut().zip(x) {
        *y += c * x;
    }
}

/// `values` zero-padded or cut to `n`, non-finite entries zeroed and counted.
fn padded(values: &[f32], n: usize, nonfinite: &mut usize) -> Vec<f32> {
    let mut out: Vec<f32> = values
        .iter()
        .take(n)
        .map(|&x| finite_or_zero(x, x.is_finite(), nonfinite))
        .collect();
    out.resize(n, 0.0);
    out
}

fn finite_vec(v: Vec3, nonfinite: &mut usize) -> Vec3 {
    finite_or_zero(v, v.is_finite(), nonfinite)
}

/// A scale vector, non-finite components replaced by 1 and counted.
fn finite_scale(s: Vec3, nonfinite: &mut usize) -> Vec3 {
    if s.is_finite() {
        s
    } else {
        *nonfinite += 1;
        Vec3::select(s.is_finite_mask(), s, Vec3::ONE)
    }
}

impl EhmModel {
    /// The reference `EHM.forward` (GUAVA's inference path). `out.joints` are the posed body
    /// joint frames, `out.rest_joints` the rest joints with offsets (`joints`), `out.skin` the
    /// per-vertex `ver_transform_mat`. Non-finite inputs are zeroed (scales: set to 1) and counted.
    pub fn forward(&self, p: &EhmParams, out: &mut PosedBody, extras: &mut EhmExtras) {
        let mut nonfinite = 0;

        // Head: FLAME with zero global and neck rotation, jaw and eyes from the tracking.
        let mut head_rotations = [Mat3A::IDENTITY; 5];
        head_rotations[FLAME_JAW] = rodrigues(p.jaw, &mut nonfinite);
        for (&j, &eye) in FLAME_EYES.iter().zip(&p.eyes) {
            head_rotations[j] = rodrigues(eye, &mut nonfinite);
        }
        let shape = padded(&p.flame_shape, self.n_shape, &mut nonfinite);
        let expression = padded(&p.flame_expression, self.n_exp, &mut nonfinite);
        let mut shaped = Vec::new();
        let [body_cache, head_cache] = &self.shape_caches.0;
        self.head
            .shaped(&shape, &expression, head_cache, &mut shaped);
        let mut head = PosedBody::default();
        let mut head_placements = Vec::new();
        self.head.skin(
            &shaped,
            &head_rotations,
            None,
            Vec3::ZERO,
            &mut head,
            &mut head_placements,
        );
        let eyelids = p
            .eyelids
            .map(|e| finite_or_zero(e, e.is_finite(), &mut nonfinite));
        let head_scale = finite_scale(p.identity.head_scale, &mut nonfinite);
        extras.head_vertices.clear();
        extras
            .head_vertices
            .extend(head.vertices.iter().enumerate().map(|(i, &v)| {
                (v + self.eyelids[1][i] * eyelids[1] + self.eyelids[0][i] * eyelids[0]) * head_scale
            }));
        let head_eyes =
            (head.joints[FLAME_EYES[0]].translation + head.joints[FLAME_EYES[1]].translation) / 2.0;

        // Body: shape + expression blend, joints with offsets, the head swapped in.
        let shape = padded(&p.shape, self.n_shape, &mut nonfinite);
        let expression = padded(&p.expression, self.n_exp, &mut nonfinite);
        self.body
            .shaped(&shape, &expression, body_cache, &mut shaped);
        let offsets: Vec<Vec3> = (0..SMPLX_JOINTS.len())
            .map(|j| {
                let o = p.identity.joints_offset.get(j).copied().unwrap_or_default();
                finite_vec(o, &mut nonfinite)
            })
            .collect();
        // Only the eye joints of the shaped body (with offsets) place the head.
        let [left, right] = SMPLX_EYES.map(|j| self.body.regress_joint(j, &shaped) + offsets[j]);
        let shift = (left + right) / 2.0 - Vec3::from(head_eyes);
        for (&b, &h) in self.head_vertices.iter().zip(&extras.head_vertices) {
            shaped[b as usize] = h + shift;
        }
        extras.head_joints.clear();
        extras.head_joints.extend(
            head.joints
                .iter()
                .map(|j| Vec3::from(j.translation) * head_scale + shift),
        );
        let hand_scale = finite_scale(p.identity.hand_scale, &mut nonfinite);
        for (hand, centre) in self.hands.iter().zip(self.hand_centres) {
            for &v in hand {
                let v = &mut shaped[v as usize];
                *v = *v * hand_scale + (Vec3::ONE - hand_scale) * centre;
            }
        }

        // Pose: global, 21 body joints, jaw and eyes zero (they live in the head), 2 × 15 hand joints.
        let mut rotations = vec![Mat3A::IDENTITY; SMPLX_JOINTS.len()];
        let posed = [
            (0, std::slice::from_ref(&p.global_pose)),
            (
                SMPLX_BODY,
                &p.body_pose[..p.body_pose.len().min(BODY_JOINTS)],
            ),
            (
                SMPLX_LEFT_HAND,
                &p.left_hand_pose[..p.left_hand_pose.len().min(HAND_JOINTS)],
            ),
            (
                SMPLX_RIGHT_HAND,
                &p.right_hand_pose[..p.right_hand_pose.len().min(HAND_JOINTS)],
            ),
        ];
        for (first, values) in posed {
            for (r, &v) in rotations[first..].iter_mut().zip(values) {
                *r = rodrigues(v, &mut nonfinite);
            }
        }
        let translation = finite_vec(p.translation, &mut nonfinite);
        self.body.skin(
            &shaped,
            &rotations,
            Some(&offsets),
            translation,
            out,
            &mut extras.placements,
        );
        out.nonfinite_inputs = nonfinite;
    }

    /// Maps a named [`BodyPose`] to EHM parameters: joints are SMPL-X's 55 (the root is the
    /// global orientation; `jaw` and the eyes drive FLAME's jaw and eyes, which is where EHM
    /// takes them from), coefficients by [`Posable::parameter_names`], identity from `self`.
    pub fn params_from_pose(&self, pose: &BodyPose) -> Result<EhmParams, PoseError> {
        pose.check_lengths(SMPLX_JOINTS.len(), self.parameter_names.len())?;
        let r = &pose.rotations;
        let (s, e) = (self.n_shape, self.n_exp);
        let c = &pose.coefficients;
        Ok(EhmParams {
            shape: c[..s].to_vec(),
            expression: c[s..s + e].to_vec(),
            global_pose: r[0],
            body_pose: r[SMPLX_BODY..SMPLX_BODY + BODY_JOINTS].to_vec(),
            left_hand_pose: r[SMPLX_LEFT_HAND..SMPLX_LEFT_HAND + HAND_JOINTS].to_vec(),
            right_hand_pose: r[SMPLX_RIGHT_HAND..SMPLX_RIGHT_HAND + HAND_JOINTS].to_vec(),
            flame_shape: c[s + e..2 * s + e].to_vec(),
            flame_expression: c[2 * s + e..2 * s + 2 * e].to_vec(),
            jaw: r[SMPLX_JAW],
            eyes: SMPLX_EYES.map(|j| r[j]),
            eyelids: [c[2 * s + 2 * e], c[2 * s + 2 * e + 1]],
            identity: self.identity.clone(),
            translation: pose.translation,
        })
    }

    /// Sets the shape and expression component counts, and the parameter names that follow from
    /// them, for a model whose meshes were replaced in memory (each [`Skinned::shape_dirs`] must
    /// then hold `n_shape + n_exp` directions).
    pub fn set_counts(&mut self, n_shape: usize, n_exp: usize) {
        self.n_shape = n_shape;
        self.n_exp = n_exp;
        self.parameter_names = Self::make_parameter_names(n_shape, n_exp);
        self.shape_caches = ShapeCaches::default();
    }

    fn make_parameter_names(n_shape: usize, n_exp: usize) -> Vec<String> {
        let numbered =
            |prefix: &'static str, n: usize| (0..n).map(move |i| format!("{prefix}{i:03}"));
        numbered("shape_", n_shape)
            .chain(numbered("expression_", n_exp))
            .chain(numbered("flame_shape_", n_shape))
            .chain(numbered("flame_expression_", n_exp))
            .chain(["eyelid_left".to_owned(), "eyelid_right".to_owned()])
            .collect()
    }
}

impl Posable for EhmModel {
    fn ehm_identity(&self) -> Option<&EhmIdentity> {
        Some(&self.identity)
    }

    /// SMPL-X or FLAME shape, rather than expression or eyelids.
    fn is_identity_parameter(&self, i: usize) -> bool {
        let (s, e) = (self.n_shape, self.n_exp);
        i < s || (s + e..2 * s + e).contains(&i)
    }

    fn joint_names(&self) -> impl ExactSizeIterator<Item = &str> {
        SMPLX_JOINTS.iter().copied()
    }

    fn parameter_names(&self) -> impl ExactSizeIterator<Item = &str> {
        self.parameter_names.iter().map(String::as_str)
    }

    fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    fn name(&self) -> &str {
        &self.name
    }

    fn vertex_count(&self) -> usize {
        self.body.template.len()
    }

    /// [`EhmModel::forward`] on the mapped parameters.
    fn pose(&self, pose: &BodyPose, out: &mut PosedBody) -> Result<(), PoseError> {
        let params = self.params_from_pose(pose)?;
        self.forward(&params, out, &mut EhmExtras::default());
        Ok(())
    }
}
