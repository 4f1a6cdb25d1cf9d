//! What each stage of the fit moves and where its priors pull: the face stage's joints,
//! expression units and head-shaping targets for a given body, and the relaxed pose the body
//! stage starts from.

use glam::{Quat, Vec3};

use super::{FACE_JOINTS, FITTED_EXPRESSIONS, FitError, JAW_JOINT};
use crate::body::{BodyModel, BodyPose, Landmark, TargetGroup, coco_limb_keypoints};

/// The joints the face stage turns ([`FACE_JOINTS`], and [`JAW_JOINT`] without `jawOpen`).
pub(super) fn face_joints(body: &BodyModel) -> Result<Vec<usize>, FitError> {
    let jaw = body.target_index("jawOpen").is_none();
    FACE_JOINTS
        .iter()
        .chain(jaw.then_some(&JAW_JOINT))
        .map(|n| {
            body.joint_index(n)
                .ok_or_else(|| FitError::MissingOnBody((*n).into()))
        })
        .collect()
}

/// The face units the face stage fits: [`FITTED_EXPRESSIONS`] where the body has them (ARKit
/// names); on a body with none of them (EHM's FLAME components), every expression target.
pub(super) fn fitted_expressions(body: &BodyModel) -> impl Iterator<Item = usize> + '_ {
    let named: Vec<usize> = FITTED_EXPRESSIONS
        .iter()
        .filter_map(|n| body.target_index(n))
        .collect();
    let all = named
        .is_empty()
        .then(|| body.targets_in(TargetGroup::Expression).map(|(i, _)| i));
    named.into_iter().chain(all.into_iter().flatten())
}

/// A shape target that moves no limb keypoint by this share of its largest vertex displacement
/// shapes the head alone ([`face_shapes`]; the default body's head size moves its shoulder
/// landmarks by 3 % of what it moves the head, its phenotypes by half or more).
const HEAD_SHAPE_LIMB_SHARE: f32 = 0.1;

/// The shape targets the face stage fits: those that move every limb keypoint's landmark by
/// less than [`HEAD_SHAPE_LIMB_SHARE`] of their largest vertex displacement (the default body's
/// [`HEAD_SIZE`](crate::body::HEAD_SIZE), which stretches the neck a little; EHM's FLAME shape components), whose size
/// and shape only the face points tell.
pub(super) fn face_shapes(body: &BodyModel) -> impl Iterator<Item = usize> + '_ {
    let limbs: Vec<&Landmark> = body
        .landmarks
        .iter()
        .filter(|l| coco_limb_keypoints().any(|n| n == l.name))
        .collect();
    body.targets_in(TargetGroup::Shape)
        .filter(move |(_, t)| {
            let deltas: std::collections::HashMap<u32, Vec3> = t
                .vertices
                .iter()
                .copied()
                .zip(t.deltas.iter().copied())
                .collect();
            let largest = t.deltas.iter().map(|d| d.length()).fold(0.0, f32::max);
            let moved = |l: &Landmark| {
                let d: Vec3 = l
                    .vertices
                    .iter()
                    .zip(&l.weights)
                    .map(|(v, &w)| w * deltas.get(v).copied().unwrap_or(Vec3::ZERO))
                    .sum();
                d.length()
            };
            !limbs.is_empty()
                && largest > 0.0
                && limbs
                    .iter()
                    .all(|l| moved(l) < HEAD_SHAPE_LIMB_SHARE * largest)
        })
        .map(|(i, _)| i)
}

/// Where a relaxed upper arm points, shoulder to elbow, on the body's left (+x; the right
/// mirrors it): the default body's rest, 48° below horizontal.
const RELAXED_UPPER_ARM: Vec3 = Vec3::new(0.665, -0.747, 0.016);
/// An upper arm resting further than this from [`RELAXED_UPPER_ARM`] (SMPL-X's T-pose, 48° away)
/// is relaxed for the fit; the default body's is not (it is the relaxed direction).
const RELAXED_ARM_TOLERANCE_RAD: f32 = 0.17;

/// The pose the fit starts from and its priors pull to: rest, with the upper arms of a rig that
/// rests them elsewhere (SMPL-X's T-pose) turned to hang as [`RELAXED_UPPER_ARM`]; so arms the
/// photo does not show hang as a person's would instead of sticking out sideways.
pub(super) fn relaxed_pose(body: &BodyModel) -> BodyPose {
    let mut pose = BodyPose::rest(body);
    for (side, mirror) in [("L", 1.0), ("R", -1.0)] {
        let joint = |name: &str| body.joint_index(&format!("{name}.{side}"));
        let (Some(shoulder), Some(elbow)) = (joint("upperarm01"), joint("lowerarm01")) else {
            continue;
        };
        let Some(rest) = (body.joints[elbow].rest - body.joints[shoulder].rest).try_normalize()
        else {
            continue;
        };
        let relaxed = (RELAXED_UPPER_ARM * Vec3::new(mirror, 1.0, 1.0)).normalize();
        if rest.angle_between(relaxed) > RELAXED_ARM_TOLERANCE_RAD {
            // Rest frames are world-aligned, so the turn is the arc from rest to relaxed.
            pose.rotations[shoulder] = Quat::from_rotation_arc(rest, relaxed).to_scaled_axis();
        }
    }
    pose
}
