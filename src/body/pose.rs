//! Named pose parameters → posed vertices, per-vertex skinning transforms and joint transforms.
//!
//! Linear blend skinning as in SMPL-X/FLAME (`flame/lbs.py`): morph the rest mesh and joints by the
//! target coefficients, chain world-aligned joint frames G_j = G_parent·[R_j | J_j − J_parent],
//! remove the rest placement (A_j = G_j·T(−J_j)), blend A_j by the skin weights per vertex.

use glam::{Affine3A, Mat3A, Quat, Vec3, Vec3A};

use super::BodyModel;

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
    #[error("the body has no target named {0:?}")]
    UnknownTarget(String),
    #[error("pose has {got} {what} for a body with {expected}")]
    WrongLength {
        what: &'static str,
        got: usize,
        expected: usize,
    },
}

impl BodyPose {
    /// The rest pose: no rotation, no translation, all coefficients zero.
    pub fn rest(model: &BodyModel) -> Self {
        Self {
            translation: Vec3::ZERO,
            rotations: vec![Vec3::ZERO; model.joints.len()],
            coefficients: vec![0.0; model.targets.len()],
        }
    }

    pub fn set_rotation(
        &mut self,
        model: &BodyModel,
        joint: &str,
        axis_angle: Vec3,
    ) -> Result<(), PoseError> {
        let j = model
            .joint_index(joint)
            .ok_or_else(|| PoseError::UnknownJoint(joint.into()))?;
        self.rotations[j] = axis_angle;
        Ok(())
    }

    pub fn set_coefficient(
        &mut self,
        model: &BodyModel,
        target: &str,
        value: f32,
    ) -> Result<(), PoseError> {
        let t = model
            .target_index(target)
            .ok_or_else(|| PoseError::UnknownTarget(target.into()))?;
        self.coefficients[t] = value;
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

/// Rotation matrix of an axis-angle vector; non-finite input is counted and treated as zero.
fn rotation(axis_angle: Vec3, nonfinite: &mut usize) -> Mat3A {
    if !axis_angle.is_finite() || !axis_angle.length_squared().is_finite() {
        *nonfinite += 1;
        return Mat3A::IDENTITY;
    }
    Mat3A::from_quat(Quat::from_scaled_axis(axis_angle))
}

fn finite_or_zero<T: Copy + Default>(value: T, finite: bool, nonfinite: &mut usize) -> T {
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
        for (what, got, expected) in [
            ("rotations", pose.rotations.len(), joint_count),
            ("coefficients", pose.coefficients.len(), self.targets.len()),
        ] {
            if got != expected {
                return Err(PoseError::WrongLength {
                    what,
                    got,
                    expected,
                });
            }
        }
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

        // Kinematic chain, then the rest placement removed: A_j = G_j · T(−J_j).
        let translation = finite_or_zero(
            pose.translation,
            pose.translation.is_finite(),
            &mut nonfinite,
        );
        out.joints.clear();
        let mut placements = Vec::with_capacity(joint_count);
        for (j, joint) in self.joints.iter().enumerate() {
            let rest = out.rest_joints[j];
            let r = rotation(pose.rotations[j], &mut nonfinite);
            let world = match joint.parent {
                Some(p) => {
                    out.joints[p]
                        * Affine3A::from_mat3_translation(r.into(), rest - out.rest_joints[p])
                }
                None => Affine3A::from_mat3_translation(r.into(), rest + translation),
            };
            out.joints.push(world);
            placements.push(Affine3A {
                matrix3: world.matrix3,
                translation: world.translation - world.matrix3 * Vec3A::from(rest),
            });
        }

        // Blend per vertex and apply.
        out.skin.clear();
        out.skin.reserve(self.vertices.len());
        for ((v, js), ws) in out
            .vertices
            .iter_mut()
            .zip(&self.skin_joints)
            .zip(&self.skin_weights)
        {
            let mut blended = Affine3A {
                matrix3: Mat3A::ZERO,
                translation: Vec3A::ZERO,
            };
            for (&j, &w) in js.iter().zip(ws) {
                if w != 0.0 {
                    let a = &placements[j as usize];
                    blended.matrix3.x_axis += w * a.matrix3.x_axis;
                    blended.matrix3.y_axis += w * a.matrix3.y_axis;
                    blended.matrix3.z_axis += w * a.matrix3.z_axis;
                    blended.translation += w * a.translation;
                }
            }
            *v = blended.transform_point3(*v);
            out.skin.push(blended);
        }
        out.nonfinite_inputs = nonfinite;
        Ok(())
    }
}
