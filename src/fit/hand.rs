//! Where MediaPipe's 21 hand points sit on the body: the wrist and finger joints are joints of
//! the rig (MakeHuman's finger1 is the thumb, its first bone the thumb's metacarpal), and the
//! fingertips, past the last joint, are the farthest skin vertex of each finger's last bone.

use super::FitError;
use crate::body::{BodyModel, Landmark};
use crate::keypoints::Side;

/// Each finger's three joints, thumb first, base to tip (without the side suffix).
const FINGERS: [[&str; 3]; 5] = [
    ["finger1-1", "finger1-2", "finger1-3"],
    ["finger2-1", "finger2-2", "finger2-3"],
    ["finger3-1", "finger3-2", "finger3-3"],
    ["finger4-1", "finger4-2", "finger4-3"],
    ["finger5-1", "finger5-2", "finger5-3"],
];

/// A point of the body that a keypoint is observed on.
#[derive(Clone, Debug, PartialEq)]
pub enum BodyPoint {
    Joint(usize),
    Surface(Landmark),
}

impl BodyPoint {
    /// Where the point is on a posed body.
    pub fn on(&self, posed: &crate::body::PosedBody) -> glam::Vec3 {
        match self {
            BodyPoint::Joint(j) => posed.joints[*j].translation.into(),
            BodyPoint::Surface(l) => l
                .vertices
                .iter()
                .zip(&l.weights)
                .map(|(&v, &w)| w * posed.vertices[v as usize])
                .sum(),
        }
    }
}

fn suffix(side: Side) -> &'static str {
    match side {
        Side::Left => ".L",
        Side::Right => ".R",
    }
}

fn joint(body: &BodyModel, name: &str, side: Side) -> Result<usize, FitError> {
    let name = format!("{name}{}", suffix(side));
    body.joint_index(&name).ok_or(FitError::MissingOnBody(name))
}

/// The body's target for each of MediaPipe's 21 hand points, in its order.
pub fn hand_targets(body: &BodyModel, side: Side) -> Result<Vec<BodyPoint>, FitError> {
    let mut targets = vec![BodyPoint::Joint(joint(body, "wrist", side)?)];
    for finger in FINGERS {
        for name in finger {
            targets.push(BodyPoint::Joint(joint(body, name, side)?));
        }
        let last = joint(body, finger[2], side)?;
        let tip = fingertip(body, last).ok_or_else(|| {
            FitError::MissingOnBody(format!("a fingertip past {}", body.joints[last].name))
        })?;
        targets.push(BodyPoint::Surface(tip));
    }
    Ok(targets)
}

/// The joints the hand stage turns: the forearm's twist and bend, the wrist, every finger joint.
pub(super) fn hand_joints(body: &BodyModel, side: Side) -> Result<Vec<usize>, FitError> {
    let mut joints = vec![
        joint(body, "lowerarm01", side)?,
        joint(body, "wrist", side)?,
    ];
    for finger in FINGERS {
        for name in finger {
            joints.push(joint(body, name, side)?);
        }
    }
    Ok(joints)
}

/// The vertex skinned mostly to `last` that lies farthest along the bone's direction.
fn fingertip(body: &BodyModel, last: usize) -> Option<Landmark> {
    let j = &body.joints[last];
    let along = (j.rest - body.joints[j.parent?].rest).normalize_or_zero();
    let dominant = |v: usize| {
        let (js, ws) = (&body.skin_joints[v], &body.skin_weights[v]);
        let k = (0..ws.len()).fold(0, |m, k| if ws[k] > ws[m] { k } else { m });
        js[k] as usize
    };
    let tip = (0..body.vertices.len())
        .filter(|&v| dominant(v) == last)
        .max_by(|&a, &b| {
            let d = |v: usize| (body.vertices[v] - j.rest).dot(along);
            d(a).total_cmp(&d(b))
        })?;
    Some(Landmark {
        name: format!("{}_tip", j.name),
        vertices: vec![tip as u32],
        weights: vec![1.0],
    })
}
