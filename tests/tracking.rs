//! Tracking files: the format's round trip and validation, playback (slerp, clock), retargeting
//! between the rigs, the shipped demo motion, and the ARKit CSV and SMPL-X npz importers.

use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use guava::body::{BodyModel, BodyPose, Posable, PosedBody, SMPLX_JOINTS};
use guava::tracking::import::{open_motion, parse_arkit_csv, smplx_npz};
use guava::tracking::{
    BodyKind, EhmIdentityRecord, Frame, Player, Retarget, TrackedCamera, Tracking, camera_at,
};

use crate::npz_writer::{npy, npy_f32, npz};

const DEMO: &str = "assets/demo_motion.json";

/// The angle between two rotations, accurate near zero (unlike an acos of the dot product).
fn angle(a: Quat, b: Quat) -> f32 {
    let d = a.inverse() * b;
    2.0 * d.xyz().length().atan2(d.w.abs())
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("guava-tracking-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// A small SMPL-X-named sequence with cameras and EHM identity.
fn sample_tracking(frames: usize) -> Tracking {
    let mut t = Tracking::new(
        BodyKind::Smplx,
        25.0,
        vec!["pelvis".into(), "left_elbow".into(), "jaw".into()],
        vec!["expression_000".into(), "eyelid_left".into()],
    );
    t.source = "test".into();
    t.identity.parameters.insert("shape_000".into(), 0.5);
    t.identity.ehm = Some(EhmIdentityRecord {
        joints_offset: vec![[0.001, -0.002, 0.0]; 55],
        head_scale: [1.0, 1.1, 0.9],
        hand_scale: [1.0; 3],
    });
    for f in 0..frames {
        let a = f as f32 * 0.1;
        t.frames.push(Frame {
            translation: [0.0, 0.01 * a, 0.0],
            rotations: vec![[0.0, a, 0.0], [0.0, 0.0, -a], [a * 0.2, 0.0, 0.0]],
            values: vec![a, 0.5],
            camera: Some(TrackedCamera {
                w2c: [
                    [1.0, 0.0, 0.0, 0.1 * a],
                    [0.0, 1.0, 0.0, 0.6],
                    [0.0, 0.0, 1.0, 22.0],
                ],
                invtanfov: 24.0,
                crop: None,
            }),
        });
    }
    t
}

#[test]
fn tracking_files_round_trip() {
    let dir = temp_dir("roundtrip");
    let path = dir.join("t.json");
    let t = sample_tracking(5);
    t.save(&path).expect("save");
    assert_eq!(Tracking::load(&path).expect("load"), t);
    assert!(!dir.join("t.json.tmp").exists());
    // The demo motion survives our writer unchanged too.
    let demo = Tracking::load(Path::new(DEMO)).expect("demo");
    demo.save(&path).expect("save demo");
    assert_eq!(Tracking::load(&path).expect("reload demo"), demo);
}

/// Each malformed document fails with a message naming the file, the frame and the field.
#[test]
fn malformed_tracking_files_name_file_frame_and_field() {
    let good = sample_tracking(3);
    let dir = temp_dir("malformed");
    let path = dir.join("good.json");
    good.save(&path).expect("save");
    let text = std::fs::read_to_string(&path).expect("read");
    let json: serde_json::Value = serde_json::from_str(&text).expect("json");
    type Edit = fn(&mut serde_json::Value);
    let cases: Vec<(Edit, &str)> = vec![
        (
            |v| v["format"] = "guava-rs tracking 9".into(),
            "bad.json: format: \"guava-rs tracking 9\"",
        ),
        (
            |v| v["fps"] = 0.0.into(),
            "bad.json: fps: 0 is not in (0, 1000]",
        ),
        (
            |v| {
                v.as_object_mut()
                    .expect("present")
                    .remove("joints")
                    .map(drop)
                    .unwrap_or(())
            },
            "bad.json: document: missing field `joints`",
        ),
        (
            |v| {
                v["frames"][2]
                    .as_object_mut()
                    .expect("present")
                    .remove("values")
                    .map(drop)
                    .unwrap_or(())
            },
            "bad.json: frame 2: frames[2]: missing field `values`",
        ),
        (
            |v| {
                v["frames"][1]["rotations"]
                    .as_array_mut()
                    .expect("present")
                    .truncate(2)
            },
            "bad.json: frame 1: rotations: 2 entries, the header lists 3",
        ),
        (
            |v| v["frames"][1]["values"][0] = "NaN".into(),
            "bad.json: frame 1: frames[1].values[0]: invalid type: string \"NaN\"",
        ),
        (
            |v| v["frames"][2]["values"][1] = 1e39.into(),
            "bad.json: frame 2: values[1] (eyelid_left): inf is not finite",
        ),
        (
            |v| v["frames"][0]["values"][0] = 500.0.into(),
            "bad.json: frame 0: values[0] (expression_000): 500 is outside ±100",
        ),
        (
            |v| v["frames"][1]["rotations"][1] = serde_json::json!([0.0, 20.0, 0.0]),
            "bad.json: frame 1: rotations[1] (left_elbow): [0.0, 20.0, 0.0] has length 20",
        ),
        (
            |v| v["frames"][2]["camera"]["w2c"][0][0] = 2.0.into(),
            "bad.json: frame 2: camera.w2c: rotation part is not a rotation",
        ),
        (
            |v| v["frames"][1]["camera"]["invtanfov"] = (-1.0).into(),
            "bad.json: frame 1: camera.invtanfov: -1 is not in (0, 1e4]",
        ),
        (
            |v| {
                v["frames"][2]
                    .as_object_mut()
                    .expect("present")
                    .remove("camera")
                    .map(drop)
                    .unwrap_or(())
            },
            "bad.json: frame 2: camera: missing here but present in frame 0",
        ),
        (
            |v| v["joints"][2] = "pelvis".into(),
            "bad.json: joints[2]: repeated name \"pelvis\"",
        ),
        (
            |v| v["identity"]["ehm"]["head_scale"][1] = 0.0.into(),
            "bad.json: identity.ehm.head_scale: 0 is not in (0, 10]",
        ),
        (
            |v| v["frames"] = serde_json::json!([]),
            "bad.json: frames: no frames",
        ),
        (
            |v| v["extra"] = 1.into(),
            "bad.json: extra: unknown field `extra`",
        ),
    ];
    for (edit, expected) in cases {
        let mut bad = json.clone();
        edit(&mut bad);
        let bytes = serde_json::to_vec(&bad).expect("json");
        let err = Tracking::from_json(&bytes, "bad.json")
            .expect_err(expected)
            .to_string();
        assert!(
            err.starts_with(expected),
            "got {err:?}, expected {expected:?}"
        );
    }
    let err = Tracking::from_json(b"{\"format\": ", "cut.json").expect_err("truncated");
    assert!(err.to_string().starts_with("cut.json: "), "{err}");
}

#[test]
fn sampling_slerps_rotations_and_blends_coefficients() {
    let model = BodyModel::default_body().expect("default body");
    let mut t = Tracking::new(
        BodyKind::Default,
        10.0,
        vec!["head".into()],
        vec!["jawOpen".into()],
    );
    // Two frames 170° apart about an oblique axis: the midpoint is the half rotation, not the
    // componentwise mean (which would have a different angle).
    let axis = Vec3::new(1.0, 2.0, 0.5).normalize();
    let (a, b) = (0.1f32, 0.1 + 170f32.to_radians());
    for (angle, jaw) in [(a, 0.0), (b, 0.8)] {
        t.frames.push(Frame {
            translation: [0.0, angle, 0.0],
            rotations: vec![(axis * angle).to_array()],
            values: vec![jaw],
            camera: None,
        });
    }
    t.validate("mem").expect("valid");
    let retarget = Retarget::new(&t, &model);
    assert_eq!(retarget.report.lines(), Vec::<String>::new());
    let mut pose = BodyPose::rest(&model);
    let head = model.joint_index("head").expect("present");
    let jaw = model.target_index("jawOpen").expect("present");
    for (time, weight) in [
        (0.0, 0.0f32),
        (0.025, 0.25),
        (0.05, 0.5),
        (0.1, 1.0),
        (5.0, 1.0),
    ] {
        retarget.sample(&t, time, &mut pose);
        let expected = axis * (a + (b - a) * weight);
        let got = Quat::from_scaled_axis(pose.rotations[head]);
        let off = angle(got, Quat::from_scaled_axis(expected));
        assert!(off < 1e-5, "t={time}: {off} rad off");
        assert!((pose.coefficients[jaw] - 0.8 * weight).abs() < 1e-6);
        assert!((pose.translation.y - (a + (b - a) * weight)).abs() < 1e-6);
    }
    // Shortest path: 350° apart the long way is 10° the short way.
    t.frames[1].rotations[0] =
        (axis * (a + 350f32.to_radians() - std::f32::consts::TAU)).to_array();
    retarget.sample(&t, 0.05, &mut pose);
    let mid = Quat::from_scaled_axis(pose.rotations[head]);
    let expected = Quat::from_scaled_axis(axis * (a - 5f32.to_radians()));
    assert!(angle(mid, expected) < 1e-5);
}

#[test]
fn tracked_camera_is_interpolated() {
    let t = sample_tracking(3);
    let (w2c, invtanfov) = camera_at(&t, 0.5 / 25.0).expect("camera");
    assert_eq!(invtanfov, 24.0);
    assert!((w2c.w_axis.x - 0.005).abs() < 1e-6, "{w2c}");
    assert!((w2c.w_axis.z - 22.0).abs() < 1e-6);
    let mut no_camera = t.clone();
    no_camera.frames.iter_mut().for_each(|f| f.camera = None);
    assert!(camera_at(&no_camera, 0.0).is_none());
}

#[test]
fn player_plays_loops_steps_and_seeks() {
    let t = sample_tracking(11); // 25 fps: 0.4 s long
    let mut p = Player::new(&t);
    assert!((p.duration() - 0.4).abs() < 1e-9);
    assert!(p.advance(0.1));
    assert!((p.time() - 0.1).abs() < 1e-9);
    assert!(p.advance(0.35)); // wraps
    assert!((p.time() - 0.05).abs() < 1e-9, "{}", p.time());
    p.speed = 2.0;
    p.advance(0.05);
    assert!((p.time() - 0.15).abs() < 1e-9);
    p.looping = false;
    p.advance(1.0);
    assert_eq!(p.time(), 0.4);
    assert!(!p.playing, "stops at the end without looping");
    assert!(!p.advance(0.1), "paused clock does not move");
    p.step(-3);
    assert_eq!(p.frame(), 7);
    p.step(100);
    assert_eq!(p.frame(), 10);
    p.seek(0.123);
    assert_eq!(p.frame(), 3);
    p.seek(f64::NAN);
    assert_eq!(p.frame(), 3);
    p.seek(-5.0);
    assert_eq!(p.time(), 0.0);
    p.speed = -1.0;
    p.playing = true;
    p.looping = true;
    p.advance(0.1);
    assert!((p.time() - 0.3).abs() < 1e-9, "backwards wraps to the end");
}

fn posed_joint(model: &BodyModel, pose: &BodyPose, name: &str) -> Vec3 {
    let mut out = PosedBody::default();
    model.pose(pose, &mut out).expect("pose");
    out.joints[model.joint_index(name).expect(name)]
        .translation
        .into()
}

/// The shipped demo motion: drives only channels the default body has, and does what the README
/// says (talks, smiles, blinks, looks around, turns the head, waves the right hand).
#[test]
fn demo_motion_moves_the_default_body() {
    let model = BodyModel::default_body().expect("default body");
    let demo = Tracking::load(Path::new(DEMO)).expect("demo motion");
    assert!(
        demo.duration() >= 6.0,
        "several seconds: {}",
        demo.duration()
    );
    let retarget = Retarget::new(&demo, &model);
    assert_eq!(retarget.report.lines(), Vec::<String>::new());
    // Layered on the rest pose, from a fresh copy each frame.
    let rest = BodyPose::rest(&model);
    let mut pose = rest.clone();
    let mut posed = PosedBody::default();
    let coefficient =
        |pose: &BodyPose, name: &str| pose.coefficients[model.target_index(name).expect("present")];
    let (mut jaw_changes, mut last_jaw, mut max_blink, mut max_smile) = (0, 0.0, 0.0f32, 0.0f32);
    let (mut max_turn, mut wrist_above_head) = (0.0f32, false);
    for f in 0..demo.frames.len() {
        pose.clone_from(&rest);
        retarget.sample(&demo, f as f64 / demo.fps as f64, &mut pose);
        model.pose(&pose, &mut posed).expect("pose");
        assert_eq!(posed.nonfinite_inputs, 0);
        assert!(posed.vertices.iter().all(|v| v.is_finite()));
        let jaw = coefficient(&pose, "jawOpen");
        if (jaw - last_jaw).abs() > 0.05 {
            jaw_changes += 1;
        }
        last_jaw = jaw;
        max_blink = max_blink.max(coefficient(&pose, "eyeBlinkLeft"));
        max_smile = max_smile.max(coefficient(&pose, "mouthSmileLeft"));
        let head = pose.rotations[model.joint_index("head").expect("present")];
        let neck = pose.rotations[model.joint_index("neck01").expect("present")];
        max_turn = max_turn.max((head.y + neck.y).abs());
        let wrist = posed.joints[model.joint_index("wrist.R").expect("present")]
            .translation
            .y;
        let head_y = posed.joints[model.joint_index("head").expect("present")]
            .translation
            .y;
        wrist_above_head |= wrist > head_y;
    }
    assert!(jaw_changes >= 10, "talking: {jaw_changes} jaw movements");
    assert!(
        max_blink > 0.9 && max_smile > 0.7,
        "blink {max_blink}, smile {max_smile}"
    );
    assert!(max_turn > 0.45, "head turn {max_turn} rad");
    assert!(
        wrist_above_head,
        "the wave lifts the right hand above the head"
    );
    // Seamless loop: first and last frames are the rest pose.
    for f in [0, demo.frames.len() - 1] {
        assert!(demo.frames[f].values.iter().all(|v| v.abs() < 1e-3));
        assert!(
            demo.frames[f]
                .rotations
                .iter()
                .flatten()
                .all(|v| v.abs() < 1e-3)
        );
    }
}

/// The demo motion is layered on the pose it drives: its first frame leaves a photo's pose as it
/// was (a turned head, a laugh), and later frames turn the joints on from there and add to the
/// photo's expression up to a unit's top. It replaced them, so every avatar the viewer opened
/// snapped to the rest pose and a neutral face the moment it moved: Grace Hopper's torso turned
/// away, a laughing photo's teeth showed on closed lips. [`Retarget::restore`] gives a pose kept
/// between samples (the viewer's) its base back.
#[test]
fn the_demo_motion_moves_an_avatar_on_from_its_photos_pose() {
    let model = BodyModel::default_body().expect("default body");
    let demo = Tracking::load(Path::new(DEMO)).expect("demo motion");
    assert!(demo.layered);
    let retarget = Retarget::new(&demo, &model);
    let joint = |name: &str| model.joint_index(name).expect("joint");
    let unit = |name: &str| model.target_index(name).expect("unit");
    let mut photo = BodyPose::rest(&model);
    photo.rotations[joint("head")] = Vec3::new(0.2, -0.3, 0.05);
    photo.rotations[joint("spine03")] = Vec3::new(0.0, 0.25, -0.1);
    photo.coefficients[unit("mouthSmileLeft")] = 0.9;
    photo.coefficients[unit("jawOpen")] = 1.2;
    let mut pose = photo.clone();
    retarget.sample(&demo, 0.0, &mut pose);
    let moved = |a: &BodyPose, b: &BodyPose| {
        let turns = a.rotations.iter().zip(&b.rotations);
        let values = a.coefficients.iter().zip(&b.coefficients);
        turns
            .map(|(x, y)| angle(Quat::from_scaled_axis(*x), Quat::from_scaled_axis(*y)))
            .chain(values.map(|(x, y)| (x - y).abs()))
            .fold(0.0f32, f32::max)
    };
    assert!(
        moved(&pose, &photo) < 1e-6,
        "the first frame leaves the photo's pose"
    );
    // Mid-smile and mid-turn (3.6 s: the smile at its 0.85, the head tilted 0.12 rad).
    let index = (3.6 * demo.fps).round() as usize;
    let frame = &demo.frames[index];
    let driven = |name: &str| {
        let k = demo
            .parameters
            .iter()
            .position(|p| p == name)
            .expect("driven");
        frame.values[k]
    };
    let track = |name: &str| {
        let k = demo.joints.iter().position(|j| j == name).expect("driven");
        Quat::from_scaled_axis(Vec3::from(frame.rotations[k]))
    };
    let time = index as f64 / demo.fps as f64;
    retarget.sample(&demo, time, &mut pose);
    let head = Quat::from_scaled_axis(pose.rotations[joint("head")]);
    let expected = Quat::from_scaled_axis(photo.rotations[joint("head")]) * track("head");
    assert!(
        angle(head, expected) < 1e-5,
        "{head:?} against {expected:?}"
    );
    assert!(angle(track("head"), Quat::IDENTITY) > 0.1, "the head moves");
    let smile = pose.coefficients[unit("mouthSmileLeft")];
    assert!(driven("mouthSmileLeft") > 0.5);
    assert!((smile - 1.0).abs() < 1e-6, "0.9 and more: {smile}");
    let jaw = pose.coefficients[unit("jawOpen")];
    assert!((jaw - 1.2).abs() < 1e-6, "past the top already: {jaw}");
    // Sampled again into the same pose, the base put back first: the same pose, not twice.
    let once = pose.clone();
    retarget.restore(&photo, &mut pose);
    retarget.sample(&demo, time, &mut pose);
    assert!(moved(&pose, &once) < 1e-6);
}

/// SMPL-X motion on the default body: names mapped, FLAME/SMPL-X expression reported as lost,
/// and the T-pose rest corrected so a zero SMPL-X pose puts the default body's arms out sideways.
#[test]
fn smplx_tracking_retargets_onto_the_default_body() {
    let model = BodyModel::default_body().expect("default body");
    let mut t = Tracking::new(
        BodyKind::Smplx,
        30.0,
        SMPLX_JOINTS.iter().map(|s| s.to_string()).collect(),
        (0..50).map(|i| format!("expression_{i:03}")).collect(),
    );
    t.frames.push(Frame {
        translation: [0.0; 3],
        rotations: vec![[0.0; 3]; 55],
        values: vec![0.0; 50],
        camera: None,
    });
    let retarget = Retarget::new(&t, &model);
    let report = &retarget.report;
    assert_eq!(report.unmapped_joints, ["left_foot", "right_foot"]);
    assert_eq!(report.unmapped_parameters.len(), 50);
    let lines = report.lines().join("\n");
    assert!(lines.contains("50 parameters have no counterpart on this body and are not applied: expression_000…expression_049 (50)"), "{lines}");
    assert!(report.rest_corrected);
    let mut pose = BodyPose::rest(&model);
    retarget.sample(&t, 0.0, &mut pose);
    for (side, sign) in [("L", 1.0), ("R", -1.0)] {
        let shoulder = posed_joint(&model, &pose, &format!("upperarm01.{side}"));
        let elbow = posed_joint(&model, &pose, &format!("lowerarm01.{side}"));
        let dir = (elbow - shoulder).normalize();
        assert!(dir.dot(Vec3::X * sign) > 0.999, "{side} arm T-pose: {dir}");
    }
    // Bending an SMPL-X elbow by 90° about y bends the default body's forearm forward by 90°.
    let elbow = SMPLX_JOINTS
        .iter()
        .position(|&n| n == "left_elbow")
        .expect("present");
    t.frames[0].rotations[elbow] = [0.0, -std::f32::consts::FRAC_PI_2, 0.0];
    retarget.sample(&t, 0.0, &mut pose);
    let e = posed_joint(&model, &pose, "lowerarm01.L");
    let w = posed_joint(&model, &pose, "wrist.L");
    let dir = (w - e).normalize();
    assert!(dir.dot(Vec3::Z) > 0.95, "forearm points forward: {dir}");
}

#[test]
fn default_motion_onto_an_smplx_rig_reports_what_it_drops() {
    // The default rig's spine has joints SMPL-X lacks; its face units have no SMPL-X parameter.
    let demo = Tracking::load(Path::new(DEMO)).expect("demo");
    struct Names;
    impl Posable for Names {
        fn joint_names(&self) -> impl ExactSizeIterator<Item = &str> {
            SMPLX_JOINTS.iter().copied()
        }
        fn parameter_names(&self) -> impl ExactSizeIterator<Item = &str> {
            ["eyelid_left"].into_iter()
        }
        fn triangles(&self) -> &[[u32; 3]] {
            &[]
        }
        fn name(&self) -> &str {
            "SMPL-X joint names"
        }
        fn vertex_count(&self) -> usize {
            0
        }
        fn is_identity_parameter(&self, _: usize) -> bool {
            false
        }
        fn pose(&self, _: &BodyPose, out: &mut PosedBody) -> Result<(), guava::body::PoseError> {
            // A T-posed skeleton: the arms along ±x.
            out.joints = SMPLX_JOINTS
                .iter()
                .map(|n| {
                    let side = if n.starts_with("left_") { 1.0 } else { -1.0 };
                    let x = match n.trim_start_matches("left_").trim_start_matches("right_") {
                        "shoulder" => 0.2,
                        "elbow" => 0.45,
                        "wrist" => 0.7,
                        "middle1" => 0.8,
                        _ => 0.0,
                    } * side;
                    glam::Affine3A::from_translation(Vec3::new(x, 1.4, 0.0))
                })
                .collect();
            Ok(())
        }
    }
    // Layered, the demo's turns are turns on either rig: its rest leaves the pose as it is.
    let layered = Retarget::new(&demo, &Names);
    assert!(!layered.report.rest_corrected);
    let mut pose = BodyPose::rest(&Names);
    layered.sample(&demo, 0.0, &mut pose);
    assert_eq!(pose, BodyPose::rest(&Names));
    // A tracked (replacing) motion of the default rig is rest corrected.
    let mut demo = demo;
    demo.layered = false;
    let retarget = Retarget::new(&demo, &Names);
    let report = &retarget.report;
    assert!(report.unmapped_joints.is_empty(), "{report:?}");
    assert_eq!(report.unmapped_parameters.len(), demo.parameters.len() - 1);
    assert_eq!(report.approximations, ["eyeBlinkLeft as eyelid_left"]);
    assert!(report.rest_corrected);
    // At rest the default body's arms hang in its A-pose; on a T-pose rig that is a shoulder
    // rotation taking the T-pose arm onto the default body's rest arm.
    retarget.sample(&demo, 0.0, &mut pose);
    let model = BodyModel::default_body().expect("default body");
    let rest = |n: &str| model.joints[model.joint_index(n).expect("present")].rest;
    let a_pose = (rest("lowerarm01.R") - rest("upperarm01.R")).normalize();
    let shoulder = SMPLX_JOINTS
        .iter()
        .position(|&n| n == "right_shoulder")
        .expect("present");
    let got = Quat::from_scaled_axis(pose.rotations[shoulder]) * Vec3::NEG_X;
    assert!(got.dot(a_pose) > 0.9999, "{got} vs {a_pose}");
}

#[test]
fn arkit_csv_imports_blendshapes_with_its_frame_rate() {
    let mut csv =
        String::from("Timecode,BlendShapeCount,EyeBlinkLeft,JawOpen,MouthSmileLeft,HeadYaw\n");
    for f in 0..90 {
        let (s, ff) = (10 + f / 60, f % 60);
        csv += &format!(
            "20:20:{s:02}:{ff:02}.500,61,{},{},0.25,0.1\n",
            (f % 10) as f32 / 10.0,
            f as f32 / 90.0
        );
    }
    let imported = parse_arkit_csv(&csv, "face.csv").expect("csv");
    let t = &imported.tracking;
    assert_eq!(t.fps, 60.0);
    assert_eq!(t.frames.len(), 90);
    assert_eq!(t.parameters, ["eyeBlinkLeft", "jawOpen", "mouthSmileLeft"]);
    assert_eq!(t.frames[45].values, [0.5, 0.5, 0.25]);
    assert!(
        imported.notes.iter().any(|n| n.contains("HeadYaw")),
        "{:?}",
        imported.notes
    );
    let model = BodyModel::default_body().expect("default body");
    assert_eq!(
        Retarget::new(t, &model).report.lines(),
        Vec::<String>::new()
    );

    let short = "EyeBlinkLeft,JawOpen\n0.1,0.2\n0.3,0.4\n";
    let imported = parse_arkit_csv(short, "short.csv").expect("no timecode");
    assert_eq!(imported.tracking.fps, 60.0);
    assert!(imported.notes[0].contains("60 fps"));

    for (bad, expected) in [
        ("", "e.csv: header: the file is empty"),
        (
            "Foo,Bar\n1,2\n",
            "e.csv: header: no ARKit blendshape columns",
        ),
        (
            "JawOpen,EyeBlinkLeft\n0.1\n",
            "e.csv: frame 0: line 2: 1 cells, the header has 2",
        ),
        (
            "JawOpen\n0.1\nabc\n",
            "e.csv: frame 1: jawOpen: \"abc\" is not a number",
        ),
        (
            "JawOpen\n0.1\n1e300\n",
            "e.csv: frame 1: values[0] (jawOpen): inf is not finite",
        ),
        (
            "Timecode,JawOpen\n12:00,0.1\n",
            "e.csv: frame 0: Timecode: \"12:00\" is not HH:MM:SS:FF",
        ),
        ("JawOpen\n", "e.csv: frames: no frames"),
    ] {
        let err = parse_arkit_csv(bad, "e.csv")
            .expect_err(expected)
            .to_string();
        assert!(
            err.starts_with(expected),
            "got {err:?}, expected {expected:?}"
        );
    }
}

#[test]
fn smplx_npz_imports_amass_and_per_part_files() {
    let dir = temp_dir("npz");
    // AMASS: 4 frames of poses [N,165], z-up.
    let n = 4;
    let mut poses = vec![0.0f32; n * 165];
    for f in 0..n {
        poses[f * 165 + 3 * 18 + 1] = 0.1 * f as f32; // left_elbow about y
    }
    let amass = npz(&[
        ("poses", npy_f32(&[n, 165], &poses)),
        ("trans", npy_f32(&[n, 3], &[0.0, 0.0, 1.0].repeat(n))),
        ("betas", npy_f32(&[16], &[0.5; 16])),
        ("mocap_frame_rate", npy("<f8", &[], &120f64.to_le_bytes())),
        ("gender", npy("|O", &[], b"\x80\x04N.")),
    ]);
    let path = dir.join("amass.npz");
    std::fs::write(&path, amass).expect("write");
    let imported = open_motion(&path).expect("amass");
    let t = &imported.tracking;
    assert_eq!((t.fps, t.frames.len(), t.body), (120.0, 4, BodyKind::Smplx));
    assert_eq!(t.identity.parameters.len(), 16);
    assert!((t.frames[2].rotations[18][1] - 0.2).abs() < 1e-6);
    // z-up → y-up: the root turns −90° about x and z-translation becomes y.
    let root = Quat::from_scaled_axis(Vec3::from(t.frames[0].rotations[0]));
    assert!(angle(root, Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2)) < 1e-5);
    assert!((Vec3::from(t.frames[0].translation) - Vec3::Y).length() < 1e-6);
    assert!(imported.notes.iter().any(|n| n.contains("z-up")));

    // Per-part fit: one frame, jaw and expression.
    let parts = npz(&[
        ("global_orient", npy_f32(&[1, 3], &[0.0, 0.3, 0.0])),
        ("body_pose", npy_f32(&[1, 63], &[0.0; 63])),
        ("jaw_pose", npy_f32(&[1, 3], &[0.2, 0.0, 0.0])),
        ("left_hand_pose", npy_f32(&[1, 45], &[0.01; 45])),
        ("right_hand_pose", npy_f32(&[1, 45], &[0.02; 45])),
        ("expression", npy_f32(&[1, 10], &[0.3; 10])),
        ("transl", npy_f32(&[1, 3], &[0.0, 0.1, 0.0])),
    ]);
    let path = dir.join("fit.npz");
    std::fs::write(&path, parts).expect("write");
    let imported = smplx_npz(&path).expect("fit");
    let t = &imported.tracking;
    assert_eq!(t.frames[0].rotations[22], [0.2, 0.0, 0.0]);
    assert_eq!(t.frames[0].rotations[54], [0.02; 3]);
    assert_eq!(t.parameters.len(), 10);
    assert!(
        imported
            .notes
            .iter()
            .any(|n| n.contains("leye_pose missing"))
    );
    assert!(imported.notes.iter().any(|n| n.contains("30 fps")));
    // Through our format and back.
    let json = dir.join("fit.json");
    t.save(&json).expect("save");
    assert_eq!(&Tracking::load(&json).expect("load"), t);

    // The same fit saved with one array per part and no frame axis (1-D `transl` and
    // `expression` were refused while 1-D poses and betas were read as one frame).
    let flat = npz(&[
        ("global_orient", npy_f32(&[3], &[0.0, 0.3, 0.0])),
        ("body_pose", npy_f32(&[63], &[0.0; 63])),
        ("jaw_pose", npy_f32(&[3], &[0.2, 0.0, 0.0])),
        ("left_hand_pose", npy_f32(&[45], &[0.01; 45])),
        ("right_hand_pose", npy_f32(&[45], &[0.02; 45])),
        ("expression", npy_f32(&[10], &[0.3; 10])),
        ("transl", npy_f32(&[3], &[0.0, 0.1, 0.0])),
    ]);
    let path = dir.join("flat.npz");
    std::fs::write(&path, flat).expect("write");
    let flat = smplx_npz(&path).expect("1-D arrays read as one frame");
    assert_eq!(flat.tracking.frames, t.frames);
    assert_eq!(flat.tracking.parameters, t.parameters);

    for (entries, expected) in [
        (
            vec![("poses", npy_f32(&[2, 100], &[0.0; 200]))],
            "bad.npz: poses: 100 values per frame, expected 165 (SMPL-X) or 156 (SMPL-H)",
        ),
        (
            vec![
                ("global_orient", npy_f32(&[1, 3], &[0.0; 3])),
                ("left_hand_pose", npy_f32(&[1, 12], &[0.0; 12])),
            ],
            "bad.npz: left_hand_pose: shape [1, 12], expected 1 frames of 15×3 values (a PCA hand pose?",
        ),
        (
            vec![("betas", npy_f32(&[10], &[0.0; 10]))],
            "bad.npz: poses: no SMPL-X pose arrays",
        ),
        (
            vec![("poses", npy_f32(&[1, 165], &[f32::NAN; 165]))],
            "bad.npz: poses: element 0 is not finite",
        ),
    ] {
        let path = dir.join("bad.npz");
        std::fs::write(&path, npz(&entries)).expect("write");
        let err = smplx_npz(&path).expect_err(expected).to_string();
        let err = err.replace(&dir.display().to_string(), "").replace('/', "");
        assert!(
            err.starts_with(expected),
            "got {err:?}, expected {expected:?}"
        );
    }
}
