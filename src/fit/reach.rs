//! An arm the body keypoints do not show, lifted to the hand the hand model found at its end: a
//! hand over the face in a close-up, where the pose model sees no body and the fit rests the
//! arm along it. The hand stage turns the forearm, wrist and fingers, which cannot bring a
//! hanging hand to the face; and from a hanging arm least squares has no good direction to
//! start in (bending the elbow first moves the wrist towards the camera, which the image does
//! not see), so the arm is placed first by two-bone inverse kinematics: the wrist at the
//! observed wrist's pixel, as near the camera as the face's front (a hand held to the face),
//! the elbow bent down and out. The hand stage goes on from there with the upper arm free.

use glam::{Quat, Vec2, Vec3};

use super::FitError;
use crate::body::{BodyModel, BodyPose, PosedBody};
use crate::camera::Camera;
use crate::keypoints::Side;

/// The arm is placed afresh ([`Arm::place`]) when the body's wrist is further than this many
/// palms (wrist to middle knuckle) from the hand model's in the image; nearer, the hand stage
/// refines it.
pub(super) const REPLACE_PALMS: f32 = 1.0;
/// Where the elbow points (before the torso's turn), on the body's left (+x; the right
/// mirrors it): down, a little out and forward, as an arm raised to the face bends.
const ELBOW_POLE: Vec3 = Vec3::new(0.4, -1.0, 0.2);
/// The wrist is placed this far behind the nose's tip (metres, from the camera): a hand held
/// to the mouth or the cheek has its wrist below the chin, about as near as the face's front.
const WRIST_BEHIND_NOSE: f32 = 0.02;

/// The joints of one arm the reach turns: the upper arm's root and the elbow; and the wrist.
#[derive(Clone, Copy)]
pub struct Arm {
    pub(super) shoulder: usize,
    elbow: usize,
    wrist: usize,
    mirror: f32,
}

impl Arm {
    pub fn of(body: &BodyModel, side: Side) -> Result<Self, FitError> {
        let (suffix, mirror) = match side {
            Side::Left => (".L", 1.0),
            Side::Right => (".R", -1.0),
        };
        let joint = |name: &str| {
            let name = format!("{name}{suffix}");
            body.joint_index(&name).ok_or(FitError::MissingOnBody(name))
        };
        Ok(Self {
            shoulder: joint("upperarm01")?,
            elbow: joint("lowerarm01")?,
            wrist: joint("wrist")?,
            mirror,
        })
    }

    /// Whether the reach turns joint `j` (the body stage leaves it be).
    pub(super) fn turns(&self, j: usize) -> bool {
        j == self.shoulder || j == self.elbow
    }

    /// `pose` with this arm placed for a wrist observed at pixel `wrist` through `camera`, as
    /// near the camera as the face's front.
    pub(super) fn place(
        &self,
        body: &BodyModel,
        pose: &BodyPose,
        camera: &Camera,
        wrist: Vec2,
    ) -> Option<BodyPose> {
        let mut posed = PosedBody::default();
        body.pose(pose, &mut posed).ok()?;
        let nose = body.landmarks.iter().position(|l| l.name == "nose")?;
        let nose = body.landmark_positions(&posed.vertices)[nose];
        let depth = camera.project(nose).z + WRIST_BEHIND_NOSE;
        self.reach(body, pose, camera.unproject(wrist.x, wrist.y, depth))
    }

    /// `pose` with this arm turned at the shoulder and the elbow so that its wrist lies at
    /// `target` (world; as near as the arm reaches), the elbow bent down, a little out and forward.
    pub fn reach(&self, body: &BodyModel, pose: &BodyPose, target: Vec3) -> Option<BodyPose> {
        let mut posed = PosedBody::default();
        body.pose(pose, &mut posed).ok()?;
        let at = |posed: &PosedBody, j: usize| Vec3::from(posed.joints[j].translation);
        // Two bones: the elbow where the upper arm and forearm (as posed) meet between the
        // shoulder and the target, in the plane the pole leans it into.
        let shoulder = at(&posed, self.shoulder);
        let (upper, lower) = (
            at(&posed, self.elbow).distance(shoulder),
            at(&posed, self.wrist).distance(at(&posed, self.elbow)),
        );
        let span = (target - shoulder).length();
        let reach = span.clamp((upper - lower).abs() + 1e-3, upper + lower - 1e-3);
        let along = (target - shoulder).try_normalize()?;
        let torso = parent_turn(body, &posed, self.shoulder)?;
        let pole = torso * (ELBOW_POLE * Vec3::new(self.mirror, 1.0, 1.0)).normalize();
        let across = (pole - pole.dot(along) * along).try_normalize()?;
        let cos = ((upper * upper + reach * reach - lower * lower) / (2.0 * upper * reach))
            .clamp(-1.0, 1.0);
        let elbow = shoulder + upper * (cos * along + (1.0 - cos * cos).sqrt() * across);
        let wrist = shoulder + reach * along;

        let mut placed = pose.clone();
        swing(body, &posed, &mut placed, self.shoulder, self.elbow, elbow)?;
        body.pose(&placed, &mut posed).ok()?;
        swing(body, &posed, &mut placed, self.elbow, self.wrist, wrist)?;
        Some(placed)
    }
}

/// The world rotation of `j`'s parent frame.
fn parent_turn(body: &BodyModel, posed: &PosedBody, j: usize) -> Option<Quat> {
    let parent = body.joints[j].parent?;
    Some(Quat::from_mat3a(&posed.joints[parent].matrix3).normalize())
}

/// Turns joint `j` (in `pose`, posed as `posed`) by the least rotation that takes its descendant
/// `end` to point at `to` from it.
fn swing(
    body: &BodyModel,
    posed: &PosedBody,
    pose: &mut BodyPose,
    j: usize,
    end: usize,
    to: Vec3,
) -> Option<()> {
    let from = Vec3::from(posed.joints[j].translation);
    let now = (Vec3::from(posed.joints[end].translation) - from).try_normalize()?;
    let turn = Quat::from_rotation_arc(now, (to - from).try_normalize()?);
    // The joint's own rotation is in its parent's frame: G' = turn · G = P · R', so
    // R' = P⁻¹ · turn · P · R.
    let parent = parent_turn(body, posed, j)?;
    let local = Quat::from_scaled_axis(pose.rotations[j]);
    pose.rotations[j] = (parent.inverse() * turn * parent * local)
        .normalize()
        .to_scaled_axis();
    Some(())
}
