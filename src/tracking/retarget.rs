//! Carrying a tracked sequence onto a body model: channels are matched by name (directly, or
//! through the SMPL-X ↔ default rig name map), arm rotations are corrected for the two rigs' rest
//! poses (SMPL-X's T-pose vs the default body's A-pose), and everything that could not be carried
//! over is listed in a [`RetargetReport`] for the user instead of being dropped silently.

use glam::{Quat, Vec3};

use super::format::{BodyKind, Tracking};
use crate::body::{BodyModel, BodyPose, Posable, PosedBody, SMPLX_JOINTS, smplx_to_default};

/// Parameters with a close counterpart on the other rig: EHM's eyelid closure (0 open … 1
/// closed) and ARKit's blink weight describe the same motion on different faces.
const SIMILAR_PARAMETERS: [(&str, &str); 4] = [
    ("eyelid_left", "eyeBlinkLeft"),
    ("eyelid_right", "eyeBlinkRight"),
    ("eyeBlinkLeft", "eyelid_left"),
    ("eyeBlinkRight", "eyelid_right"),
];

/// How one tracked joint lands on the model: `R_model = pre · R_track · post`.
#[derive(Clone, Debug)]
struct JointLink {
    track: usize,
    model: usize,
    pre: Quat,
    post: Quat,
}

/// A tracked sequence matched to one model's joints and parameters.
#[derive(Clone, Debug)]
pub struct Retarget {
    joints: Vec<JointLink>,
    /// (track parameter, model parameter).
    parameters: Vec<(usize, usize)>,
    /// Identity values (model parameter, value), set on every sampled pose.
    identity: Vec<(usize, f32)>,
    pub report: RetargetReport,
}

/// What was carried over and what was not.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RetargetReport {
    pub joints_mapped: usize,
    pub parameters_mapped: usize,
    pub unmapped_joints: Vec<String>,
    pub unmapped_parameters: Vec<String>,
    pub unmapped_identity: Vec<String>,
    /// The file has EHM identity (joint offsets, head and hand scale) that this model does not use.
    pub ehm_identity_ignored: bool,
    /// Arm rotations were corrected for a different rest pose (T-pose and A-pose).
    pub rest_corrected: bool,
    /// Parameters carried onto a similar but not equivalent one (`from → to`).
    pub approximations: Vec<String>,
}

impl RetargetReport {
    /// One line per kind of loss, with runs of numbered names collapsed
    /// (`expression_000…expression_049 (50)`).
    pub fn lines(&self) -> Vec<String> {
        let mut lines = Vec::new();
        for (what, names) in [
            ("joints", &self.unmapped_joints),
            ("parameters", &self.unmapped_parameters),
            ("identity parameters", &self.unmapped_identity),
        ] {
            if !names.is_empty() {
                lines.push(format!(
                    "{} {what} have no counterpart on this body and are not applied: {}",
                    names.len(),
                    collapse_runs(names)
                ));
            }
        }
        if self.ehm_identity_ignored {
            lines.push(
                "EHM joint offsets and head/hand scales apply only to an EHM body and are not applied"
                    .into(),
            );
        }
        if !self.approximations.is_empty() {
            lines.push(format!(
                "approximated by a similar parameter: {}",
                self.approximations.join(", ")
            ));
        }
        if self.rest_corrected {
            lines.push(
                "arm rotations corrected for the rigs' different rest poses (T-pose and A-pose); \
                 the spine and hands are approximate"
                    .into(),
            );
        }
        lines
    }
}

/// `a_000, a_001, …, a_049, b` → `a_000…a_049 (50), b`.
fn collapse_runs(names: &[String]) -> String {
    let stem = |n: &str| n.trim_end_matches(|c: char| c.is_ascii_digit()).to_owned();
    let mut parts = Vec::new();
    let mut i = 0;
    while i < names.len() {
        let s = stem(&names[i]);
        let mut j = i + 1;
        while j < names.len() && s.len() < names[i].len() && stem(&names[j]) == s {
            j += 1;
        }
        parts.push(if j - i > 2 {
            format!("{}…{} ({})", names[i], names[j - 1], j - i)
        } else {
            names[i..j].join(", ")
        });
        i = j;
    }
    parts.join(", ")
}

/// The rig a model's joint names belong to, if it is one of the two known ones.
pub(crate) fn rig_of(model: &impl Posable) -> Option<BodyKind> {
    let has = |name: &str| model.joint_names().any(|n| n == name);
    if has("pelvis") && has("left_shoulder") {
        Some(BodyKind::Smplx)
    } else if has("root") && has("upperarm01.L") {
        Some(BodyKind::Default)
    } else {
        None
    }
}

/// The SMPL-X name of a joint of the given rig.
fn smplx_name(kind: BodyKind, name: &str) -> Option<String> {
    match kind {
        BodyKind::Smplx => Some(name.to_owned()),
        BodyKind::Default => SMPLX_JOINTS
            .iter()
            .find(|s| smplx_to_default(s).as_deref() == Some(name))
            .map(|s| (*s).to_owned()),
    }
}

/// A joint's name on a rig, from its SMPL-X name.
fn rig_name(kind: BodyKind, smplx: &str) -> Option<String> {
    match kind {
        BodyKind::Smplx => Some(smplx.to_owned()),
        BodyKind::Default => smplx_to_default(smplx),
    }
}

/// The arm bones whose rest directions the correction aligns: upper arm, forearm, hand.
const ARM_BONES: [(&str, &str); 3] = [
    ("shoulder", "elbow"),
    ("elbow", "wrist"),
    ("wrist", "middle1"),
];

/// Unit rest directions of each arm's bones, `[side][bone]` (left, right; [`ARM_BONES`]).
type ArmBones = [[Vec3; 3]; 2];

fn rest_arm_bones(model: &impl Posable, kind: BodyKind) -> Option<ArmBones> {
    let mut posed = PosedBody::default();
    model.pose(&BodyPose::rest(model), &mut posed).ok()?;
    let position = |smplx: &str| {
        let name = rig_name(kind, smplx)?;
        let j = model.joint_names().position(|n| n == name)?;
        Some(Vec3::from(posed.joints[j].translation))
    };
    let bone = |side: &str, (from, to): (&str, &str)| {
        (position(&format!("{side}_{to}"))? - position(&format!("{side}_{from}"))?).try_normalize()
    };
    let arm = |side: &str| -> Option<[Vec3; 3]> {
        Some([
            bone(side, ARM_BONES[0])?,
            bone(side, ARM_BONES[1])?,
            bone(side, ARM_BONES[2])?,
        ])
    };
    Some([arm("left")?, arm("right")?])
}

/// The rest arm bones of a tracked rig: SMPL-X's T-pose (every arm bone along ±x), or the
/// embedded default body's.
fn source_arm_bones(kind: BodyKind) -> Option<ArmBones> {
    match kind {
        BodyKind::Smplx => Some([[Vec3::X; 3], [Vec3::NEG_X; 3]]),
        BodyKind::Default => rest_arm_bones(&BodyModel::default_body().ok()?, BodyKind::Default),
    }
}

/// An arm joint's side (0 left, 1 right), the bone it turns, and its parent's bone (none for the
/// shoulder, whose parent, the collar, has the same rest on both rigs).
fn arm_joint(smplx: &str) -> Option<(usize, usize, Option<usize>)> {
    let (side, rest) = if let Some(rest) = smplx.strip_prefix("left_") {
        (0, rest)
    } else {
        (1, smplx.strip_prefix("right_")?)
    };
    let fingers = ["index", "middle", "ring", "pinky", "thumb"];
    let (bone, parent) = match rest {
        "shoulder" => (0, None),
        "elbow" => (1, Some(0)),
        "wrist" => (2, Some(1)),
        _ if fingers.iter().any(|f| rest.starts_with(f)) => (2, Some(2)),
        _ => return None,
    };
    Some((side, bone, parent))
}

impl Retarget {
    pub fn new(tracking: &Tracking, model: &impl Posable) -> Self {
        let model_rig = rig_of(model);
        let mut report = RetargetReport::default();
        // Rest correction: Q_b takes the model's rest direction of arm bone b onto the tracked
        // rig's. A joint turning bone b under parent bone p gets Q_p⁻¹·R·Q_b, so every posed
        // bone points where the tracked rig's would.
        // A layered motion's rotations are turns from wherever the joints are, the same turn in
        // either rig's world-aligned frames: it needs none.
        let corrections: Option<[[Quat; 3]; 2]> = match model_rig {
            Some(rig) if rig != tracking.body && !tracking.layered => rest_arm_bones(model, rig)
                .zip(source_arm_bones(tracking.body))
                .map(|(to, from)| {
                    [0, 1].map(|s| [0, 1, 2].map(|b| Quat::from_rotation_arc(to[s][b], from[s][b])))
                }),
            _ => None,
        };
        let model_joint = |name: &str| model.joint_names().position(|n| n == name);
        let mut joints = Vec::new();
        for (t, name) in tracking.joints.iter().enumerate() {
            let smplx = smplx_name(tracking.body, name);
            let found = model_joint(name).or_else(|| {
                let rig = model_rig?;
                model_joint(&rig_name(rig, smplx.as_deref()?)?)
            });
            let Some(m) = found else {
                report.unmapped_joints.push(name.clone());
                continue;
            };
            let (mut pre, mut post) = (Quat::IDENTITY, Quat::IDENTITY);
            if let (Some(q), Some((side, bone, parent))) =
                (corrections, smplx.as_deref().and_then(arm_joint))
            {
                post = q[side][bone];
                if let Some(p) = parent {
                    pre = q[side][p].inverse();
                }
                report.rest_corrected = true;
            }
            joints.push(JointLink {
                track: t,
                model: m,
                pre,
                post,
            });
        }
        let model_parameter = |name: &str| model.parameter_names().position(|n| n == name);
        let mut parameters = Vec::new();
        for (t, name) in tracking.parameters.iter().enumerate() {
            let similar = SIMILAR_PARAMETERS
                .iter()
                .find(|(from, _)| from == name)
                .and_then(|&(from, to)| Some((model_parameter(to)?, format!("{from} as {to}"))));
            match (model_parameter(name), similar) {
                (Some(m), _) => parameters.push((t, m)),
                (None, Some((m, note))) => {
                    parameters.push((t, m));
                    report.approximations.push(note);
                }
                (None, None) => report.unmapped_parameters.push(name.clone()),
            }
        }
        let mut identity = Vec::new();
        for (name, &value) in &tracking.identity.parameters {
            match model_parameter(name) {
                Some(m) => identity.push((m, value)),
                None => report.unmapped_identity.push(name.clone()),
            }
        }
        report.ehm_identity_ignored =
            tracking.identity.ehm.is_some() && model.ehm_identity().is_none();
        report.joints_mapped = joints.len();
        report.parameters_mapped = parameters.len();
        Self {
            joints,
            parameters,
            identity,
            report,
        }
    }

    /// The pose at `time` (seconds, clamped to the sequence): rotations slerped and coefficients
    /// blended linearly between the two nearest frames. Writes only the channels the tracking
    /// drives; the rest of `pose` (joints it lacks, hand-set sliders) is left as it is. A
    /// layered tracking ([`Tracking::layered`]) turns each joint on from `pose`'s rotation and
    /// adds to its values and translation, so `pose` must then hold the base each time (a fresh
    /// copy, or [`Self::restore`]). `pose` must belong to the model this was built for.
    /// Allocates nothing.
    pub fn sample(&self, tracking: &Tracking, time: f64, pose: &mut BodyPose) {
        let (a, b, t) = bracket(tracking, time);
        let (fa, fb) = (&tracking.frames[a], &tracking.frames[b]);
        let translation = Vec3::from(fa.translation).lerp(Vec3::from(fb.translation), t);
        pose.translation = match tracking.layered {
            true => pose.translation + translation,
            false => translation,
        };
        for link in &self.joints {
            let qa = Quat::from_scaled_axis(Vec3::from(fa.rotations[link.track]));
            let q = if t == 0.0 {
                qa
            } else {
                qa.slerp(
                    Quat::from_scaled_axis(Vec3::from(fb.rotations[link.track])),
                    t,
                )
            };
            let rotation = &mut pose.rotations[link.model];
            *rotation = if tracking.layered {
                (Quat::from_scaled_axis(*rotation) * q)
                    .normalize()
                    .to_scaled_axis()
            } else if link.pre == Quat::IDENTITY && link.post == Quat::IDENTITY {
                if t == 0.0 {
                    Vec3::from(fa.rotations[link.track])
                } else {
                    q.to_scaled_axis()
                }
            } else {
                (link.pre * q * link.post).normalize().to_scaled_axis()
            };
        }
        for &(tr, m) in &self.parameters {
            let value = fa.values[tr] + (fb.values[tr] - fa.values[tr]) * t;
            let coefficient = &mut pose.coefficients[m];
            *coefficient = match tracking.layered {
                true => layer(*coefficient, value),
                false => value,
            };
        }
        for &(m, v) in &self.identity {
            pose.coefficients[m] = v;
        }
    }

    /// Puts `base`'s values back on the channels this tracking drives, for a pose kept from one
    /// sample to the next under a layered tracking (the viewer's).
    pub fn restore(&self, base: &BodyPose, pose: &mut BodyPose) {
        pose.translation = base.translation;
        for link in &self.joints {
            pose.rotations[link.model] = base.rotations[link.model];
        }
        for &(_, m) in &self.parameters {
            pose.coefficients[m] = base.coefficients[m];
        }
    }
}

/// A layered value added to `base`'s, up to a unit's top (1) or to `base` where the photo is
/// already past it: a smile layered on a laughing face stays a laugh, not twice one.
fn layer(base: f32, value: f32) -> f32 {
    (base + value).min(base.max(1.0))
}

/// The frames around `time` and the blend weight of the second.
pub(crate) fn bracket(tracking: &Tracking, time: f64) -> (usize, usize, f32) {
    let last = tracking.frames.len() - 1;
    let f = (time * tracking.fps as f64).clamp(0.0, last as f64);
    let f = if f.is_finite() { f } else { 0.0 };
    let a = (f.floor() as usize).min(last);
    let b = (a + 1).min(last);
    (a, b, (f - a as f64) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbered_runs_collapse() {
        let names: Vec<String> = (0..50)
            .map(|i| format!("expression_{i:03}"))
            .chain(["eyelid_left".into(), "eyelid_right".into()])
            .collect();
        assert_eq!(
            collapse_runs(&names),
            "expression_000…expression_049 (50), eyelid_left, eyelid_right"
        );
    }

    #[test]
    fn arm_joints_are_recognised() {
        assert_eq!(arm_joint("left_shoulder"), Some((0, 0, None)));
        assert_eq!(arm_joint("left_elbow"), Some((0, 1, Some(0))));
        assert_eq!(arm_joint("right_index2"), Some((1, 2, Some(2))));
        assert_eq!(arm_joint("left_hip"), None);
        assert_eq!(arm_joint("neck"), None);
    }
}
