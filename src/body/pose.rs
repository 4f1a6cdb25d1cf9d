//! Named pose parameters → posed vertices, per-vertex skinning transforms and joint transforms.
//!
//! Linear blend skinning as in SMPL-X/FLAME (`flame/lbs.py`): morph the rest mesh and joints by the
//! target coefficients, chain world-aligned joint frames G_j = G_parent·[R_j | J_j − J_parent],
//! remove the rest placement (A_j = G_j·T(−J_j)), blend A_j by the skin weights per vertex.

use glam::{Affine3A, Mat3A, Vec3};

use super::BodyModel;
use super::lbs::{blend, rigid_chain, rodrigues};

/// Pose parameters, indexed like the model's joints and targets; set them by name.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyPose {
    /// Added to every posed point (metres).
    pub translation: Vec3,
    /// Axis-angle rotation of each joint in its world-aligned rest frame (radians). The root
    /// joint's rotation is the global orientation.
    pub rotations: Vec<Vec3>,
    /// One coefficient per morph target (shape, expression, pose correctives).
    pub coefficients: Vec<f32>,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PoseError {
    #[error("the body has no joint named {0:?}")]
    UnknownJoint(String),
    #[error("the body has no parameter named {0:?}")]
    UnknownParameter(String),
    #[error("pose has {got} {what} for a body with {expected}")]
    WrongLength {
        what: &'static str,
        got: usize,
        expected: usize,
    },
}

/// What every body model offers: named joints and parameters in, a posed body out.
pub trait Posable {
    /// Joint names; a [`BodyPose`] has one rotation per joint in this order.
    fn joint_names(&self) -> impl ExactSizeIterator<Item = &str>;
    /// Parameter (coefficient) names; a [`BodyPose`] has one coefficient per name in this order.
    fn parameter_names(&self) -> impl ExactSizeIterator<Item = &str>;
    fn triangles(&self) -> &[[u32; 3]];
    /// The model's name, which avatars record to say what they are bound to.
    fn name(&self) -> &str;
    fn vertex_count(&self) -> usize;
    /// Poses into `out` (reused across frames). Non-finite inputs are treated as zero and counted.
    fn pose(&self, pose: &BodyPose, out: &mut PosedBody) -> Result<(), PoseError>;
    /// Whether parameter `i` belongs to the person (shape), not to a moment (expression, pose).
    fn is_identity_parameter(&self, i: usize) -> bool;
    /// EHM's identity (joint offsets, head and hand scale) for a model that takes one.
    fn ehm_identity(&self) -> Option<&super::EhmIdentity> {
        None
    }
    /// For each vertex, the vertex it is welded to, where the mesh splits vertices at UV seams
    /// (smooth normals are shared across them); `None` when it splits none.
    fn weld(&self) -> Option<&[u32]> {
        None
    }
    /// The body part vertex `v` belongs to (`hand.L`, `head`, …); `None` on a body without part
    /// labels.
    fn part_of(&self, _v: usize) -> Option<&str> {
        None
    }
    /// The joint that moves vertex `v` most; `None` on a body that does not say.
    fn dominant_joint(&self, _v: usize) -> Option<usize> {
        None
    }
}

impl BodyPose {
    /// The rest pose: no rotation, no translation, all coefficients zero.
    pub fn rest(model: &impl Posable) -> Self {
        Self {
            translation: Vec3::ZERO,
            rotations: vec![Vec3::ZERO; model.joint_names().len()],
            coefficients: vec![0.0; model.parameter_names().len()],
        }
    }

    pub fn set_rotation(
        &mut self,
        model: &impl Posable,
        joint: &str,
        axis_angle: Vec3,
    ) -> Result<(), PoseError> {
        let j = model
            .joint_names()
            .position(|n| n == joint)
            .ok_or_else(|| PoseError::UnknownJoint(joint.into()))?;
        self.rotations[j] = axis_angle;
        Ok(())
    }

    pub fn set_coefficient(
        &mut self,
        model: &impl Posable,
        name: &str,
        value: f32,
    ) -> Result<(), PoseError> {
        let t = model
            .parameter_names()
            .position(|n| n == name)
            .ok_or_else(|| PoseError::UnknownParameter(name.into()))?;
        self.coefficients[t] = value;
        Ok(())
    }

    /// Checks the lengths against a model with `joints` joints and `parameters` parameters.
    pub(crate) fn check_lengths(&self, joints: usize, parameters: usize) -> Result<(), PoseError> {
        for (what, got, expected) in [
            ("rotations", self.rotations.len(), joints),
            ("coefficients", self.coefficients.len(), parameters),
        ] {
            if got != expected {
                return Err(PoseError::WrongLength {
                    what,
                    got,
                    expected,
                });
            }
        }
        Ok(())
    }
}

/// The result of posing, reusable across frames (posing into it allocates only on first use).
#[derive(Clone, Debug, Default)]
pub struct PosedBody {
    pub vertices: Vec<Vec3>,
    /// Blended skinning transform of each vertex: posed = skin · (rest + morph deltas). Its
    /// linear part is what rotates a vertex-bound Gaussian.
    pub skin: Vec<Affine3A>,
    /// World transform of each joint's frame (its translation is the posed joint position).
    pub joints: Vec<Affine3A>,
    /// Rest joint positions after the shape/expression morphs.
    pub rest_joints: Vec<Vec3>,
    /// How many input values were NaN or infinite and were treated as zero.
    pub nonfinite_inputs: usize,
}

pub(crate) fn finite_or_zero<T: Copy + Default>(
    value: T,
    finite: bool,
    nonfinite: &mut usize,
) -> T {
    if finite {
        value
    } else {
        *nonfinite += 1;
        T::default()
    }
}

impl BodyModel {
    /// Poses the body into `out`. Non-finite parameters are treated as zero and counted in
    /// `out.nonfinite_inputs`, so the output is always finite for finite assets.
    pub fn pose(&self, pose: &BodyPose, out: &mut PosedBody) -> Result<(), PoseError> {
        let joint_count = self.joints.len();
        pose.check_lengths(joint_count, self.targets.len())?;
        let mut nonfinite = 0;

        // Morphs: rest mesh and joints plus the weighted target deltas.
        out.vertices.clear();
        out.vertices.extend_from_slice(&self.vertices);
        out.rest_joints.clear();
        out.rest_joints.extend(self.joints.iter().map(|j| j.rest));
        for (target, &c) in self.targets.iter().zip(&pose.coefficients) {
            let c = finite_or_zero(c, c.is_finite(), &mut nonfinite);
            if c == 0.0 {
                continue;
            }
            for (&v, &d) in target.vertices.iter().zip(&target.deltas) {
                out.vertices[v as usize] += c * d;
            }
            for (j, &d) in out.rest_joints.iter_mut().zip(&target.joint_deltas) {
                *j += c * d;
            }
        }

        let translation = finite_or_zero(
            pose.translation,
            pose.translation.is_finite(),
            &mut nonfinite,
        );
        let rotations: Vec<Mat3A> = pose
            .rotations
            .iter()
            .map(|&r| rodrigues(r, &mut nonfinite))
            .collect();
        let mut placements = Vec::with_capacity(joint_count);
        rigid_chain(
            self.joints.iter().map(|j| j.parent),
            &out.rest_joints,
            &rotations,
            translation,
            &mut out.joints,
            &mut placements,
        );

        out.skin.clear();
        out.skin.reserve(self.vertices.len());
        for ((v, js), ws) in out
            .vertices
            .iter_mut()
            .zip(&self.skin_joints)
            .zip(&self.skin_weights)
        {
            let influences = js.iter().zip(ws).filter(|(_, w)| **w != 0.0);
            let skin = blend(influences.map(|(&j, &w)| (j as usize, w)), &placements);
            *v = skin.transform_point3(*v);
            out.skin.push(skin);
        }
        out.nonfinite_inputs = nonfinite;
        Ok(())
    }
}

impl Posable for BodyModel {
    fn joint_names(&self) -> impl ExactSizeIterator<Item = &str> {
        self.joints.iter().map(|j| j.name.as_str())
    }

    fn parameter_names(&self) -> impl ExactSizeIterator<Item = &str> {
        self.targets.iter().map(|t| t.name.as_str())
    }

    fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    fn name(&self) -> &str {
        &self.name
    }

    fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    fn pose(&self, pose: &BodyPose, out: &mut PosedBody) -> Result<(), PoseError> {
        BodyModel::pose(self, pose, out)
    }

    fn is_identity_parameter(&self, i: usize) -> bool {
        self.targets[i].group == super::TargetGroup::Shape
    }

    fn weld(&self) -> Option<&[u32]> {
        Some(&self.weld)
    }

    fn part_of(&self, v: usize) -> Option<&str> {
        BodyModel::part_of(self, v)
    }

    fn dominant_joint(&self, v: usize) -> Option<usize> {
        Some(BodyModel::dominant_joint(self, v))
    }
}
