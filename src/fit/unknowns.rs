//! What each stage of the fit moves and where its priors pull: the face stage's joints,
//! expression units and head-shaping targets for a given body, and the relaxed pose the body
//! stage starts from.

use glam::{Quat, Vec3};

use super::problem::Unknown;
use super::{FACE_JOINTS, FITTED_EXPRESSIONS, FitError, JAW_JOINT, PRIOR_PX_PER_RAD};
use crate::body::{BodyModel, BodyPose, Landmark, TargetGroup, coco_limb_keypoints};

/// The global orientation's prior about the vertical: weak, people face the camera at any angle.
const YAW_PRIOR_PX_PER_RAD: f64 = 2.0;
/// About the other two axes: people in an upper-body photo sit or stand upright. A camera this
/// far away barely sees a lean toward or away from it, so the keypoints leave it loose: with the
/// yaw's prior on all three axes the fit laid the demo portrait's torso 65° back and bent the
/// spine forward to right the head (upright from the front, lying down from the side), and the
/// drawn body (no lean) 67°.
const UPRIGHT_ROOT_PX_PER_RAD: f64 = 100.0;
/// The joints between pelvis and head whose pitch would lean the torso instead.
const UPRIGHT_JOINTS: [&str; 2] = ["spine03", "neck01"];
const UPRIGHT_PITCH_PX_PER_RAD: f64 = 200.0;

/// The global orientation (axis-angle about the body's x, y (up) and z) and the camera
/// translation, with their priors.
pub(super) fn root_and_camera() -> impl Iterator<Item = (Unknown, f64)> {
    [
        UPRIGHT_ROOT_PX_PER_RAD,
        YAW_PRIOR_PX_PER_RAD,
        UPRIGHT_ROOT_PX_PER_RAD,
    ]
    .into_iter()
    .enumerate()
    .map(|(k, prior)| (Unknown::Joint(0, k), prior))
    .chain((0..3).map(|k| (Unknown::Camera(k), 0.0)))
}

/// Joint `j`'s three axis-angle components with their priors: [`PRIOR_PX_PER_RAD`], and the
/// pitch of the [`UPRIGHT_JOINTS`] at [`UPRIGHT_PITCH_PX_PER_RAD`].
pub(super) fn joint_unknowns(body: &BodyModel, j: usize) -> impl Iterator<Item = (Unknown, f64)> {
    let upright = UPRIGHT_JOINTS
        .iter()
        .any(|n| body.joint_index(n) == Some(j));
    let pitch = if upright {
        UPRIGHT_PITCH_PX_PER_RAD
    } else {
        PRIOR_PX_PER_RAD
    };
    [pitch, PRIOR_PX_PER_RAD, PRIOR_PX_PER_RAD]
        .into_iter()
        .enumerate()
        .map(move |(k, prior)| (Unknown::Joint(j, k), prior))
}

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
/// Where an arm the photo does not show rests: along the body, 75° below horizontal (the relaxed
/// hang above would stand out from a person's sides into the background).
const ALONG_BODY_UPPER_ARM: Vec3 = Vec3::new(0.259, -0.966, 0.0);
/// An upper arm resting further than this from [`RELAXED_UPPER_ARM`] (SMPL-X's T-pose, 48° away)
/// is relaxed for the fit; the default body's is not (it is the relaxed direction).
const RELAXED_ARM_TOLERANCE_RAD: f32 = 0.17;

/// The pose the fit starts from and its priors pull to: rest, with the upper arms of a rig that
/// rests them elsewhere (SMPL-X's T-pose) turned to hang as [`RELAXED_UPPER_ARM`], and the arms
/// the photo does not show (`unseen`: left, right) along the body ([`ALONG_BODY_UPPER_ARM`]); so arms the
/// photo does not show hang as a person's would instead of sticking out sideways.
pub(super) fn relaxed_pose(body: &BodyModel, unseen: [bool; 2]) -> BodyPose {
    let mut pose = BodyPose::rest(body);
    for ((side, mirror), unseen) in [("L", 1.0), ("R", -1.0)].into_iter().zip(unseen) {
        let joint = |name: &str| body.joint_index(&format!("{name}.{side}"));
        let (Some(shoulder), Some(elbow)) = (joint("upperarm01"), joint("lowerarm01")) else {
            continue;
        };
        let Some(rest) = (body.joints[elbow].rest - body.joints[shoulder].rest).try_normalize()
        else {
            continue;
        };
        let hang = if unseen {
            ALONG_BODY_UPPER_ARM
        } else {
            RELAXED_UPPER_ARM
        };
        let relaxed = (hang * Vec3::new(mirror, 1.0, 1.0)).normalize();
        if unseen || rest.angle_between(relaxed) > RELAXED_ARM_TOLERANCE_RAD {
            // Rest frames are world-aligned, so the turn is the arc from rest to relaxed.
            pose.rotations[shoulder] = Quat::from_rotation_arc(rest, relaxed).to_scaled_axis();
        }
    }
    pose
}
