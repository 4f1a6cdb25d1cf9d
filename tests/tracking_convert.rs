//! tools/convert_ehm_tracking.py on a synthetic EHM-Tracker output with the real key layout
//! (tests/data/ehm_tracker, from tools/make_ehm_tracking_fixture.py): every mapped value lands in
//! the right channel, the camera is turned into OpenCV axes, and the result plays on EHM.
//! Runs the converter with `python3` (or `$GUAVA_PYTHON`), which needs NumPy (tools/setup.sh).

use std::path::Path;
use std::process::Command;

use guava::body::{BodyPose, EhmModel, Posable, PosedBody, SMPLX_JOINTS};
use guava::npz::Npz;
use guava::tracking::{Retarget, Tracking};

const FIXTURE: &str = "tests/data/ehm_tracker";

fn convert(args: &[&str], out: &Path) -> std::process::Output {
    let python = std::env::var("GUAVA_PYTHON").unwrap_or_else(|_| "python3".into());
    Command::new(&python)
        .arg("tools/convert_ehm_tracking.py")
        .arg(FIXTURE)
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap_or_else(|e| panic!("running {python} (tools/setup.sh installs NumPy): {e}"))
}

#[test]
fn ehm_tracker_output_converts_channel_by_channel() {
    let dir = std::env::temp_dir().join(format!("guava-convert-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let out = dir.join("clip_a.json");
    let run = convert(&["--video", "clip_a", "--fps", "25"], &out);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let t = Tracking::load(&out).expect("the converted file validates");
    let raw = Npz::open(Path::new(&format!("{FIXTURE}/expected.npz"))).expect("expected values");
    let get = |name: &str| raw.f32s(name, &[None; 1]).map(|(d, _)| d.to_vec());
    let all = |name: &str| {
        let rank = raw.shape(name).expect(name).len();
        raw.f32s(name, &vec![None; rank]).expect(name).0.to_vec()
    };

    assert_eq!(t.fps, 25.0);
    assert_eq!(t.joints, SMPLX_JOINTS);
    assert_eq!(t.frames.len(), 3);
    let (global, body, jaw, eyes) = (
        all("global_pose"),
        all("body_pose"),
        all("jaw"),
        all("eyes"),
    );
    let (left, right) = (all("left_hand"), all("right_hand"));
    let (exp, flame_exp, eyelids, rt) = (all("exp"), all("flame_exp"), all("eyelids"), all("rt"));
    for (f, frame) in t.frames.iter().enumerate() {
        let r = |j: usize| frame.rotations[j].to_vec();
        assert_eq!(r(0), global[f * 3..f * 3 + 3]);
        for j in 0..21 {
            assert_eq!(
                r(1 + j),
                body[f * 63 + 3 * j..f * 63 + 3 * j + 3],
                "body joint {j}"
            );
        }
        assert_eq!(r(22), jaw[f * 3..f * 3 + 3], "jaw from FLAME");
        assert_eq!(r(23), eyes[f * 6..f * 6 + 3], "left eye first");
        assert_eq!(r(24), eyes[f * 6 + 3..f * 6 + 6]);
        for k in 0..15 {
            assert_eq!(r(25 + k), left[f * 45 + 3 * k..f * 45 + 3 * k + 3]);
            assert_eq!(r(40 + k), right[f * 45 + 3 * k..f * 45 + 3 * k + 3]);
        }
        let value =
            |name: &str| frame.values[t.parameters.iter().position(|p| p == name).expect(name)];
        for i in 0..50 {
            assert_eq!(value(&format!("expression_{i:03}")), exp[f * 50 + i]);
            assert_eq!(
                value(&format!("flame_expression_{i:03}")),
                flame_exp[f * 50 + i]
            );
        }
        assert_eq!(value("eyelid_left"), eyelids[f * 2]);
        assert_eq!(value("eyelid_right"), eyelids[f * 2 + 1]);
        // w2c = diag(-1, -1, 1)·[R | T]: PyTorch3D axes → OpenCV axes (data_loader.py).
        let camera = frame.camera.expect("camera");
        assert_eq!(camera.invtanfov, 24.0);
        for (row, sign) in [(0, -1.0f32), (1, -1.0), (2, 1.0)] {
            for col in 0..4 {
                assert_eq!(camera.w2c[row][col], sign * rt[f * 12 + row * 4 + col]);
            }
        }
    }
    let shape = get("smplx_shape").expect("shape");
    for (i, &b) in shape.iter().enumerate() {
        assert_eq!(t.identity.parameters[&format!("shape_{i:03}")], b);
    }
    let flame_shape = get("flame_shape").expect("flame shape");
    assert_eq!(
        t.identity.parameters[&format!("flame_shape_{:03}", 299)],
        flame_shape[299]
    );
    let ehm = t.identity.ehm.as_ref().expect("EHM identity");
    assert_eq!(
        ehm.joints_offset
            .iter()
            .flatten()
            .copied()
            .collect::<Vec<_>>(),
        all("joints_offset")
    );
    assert_eq!(
        ehm.head_scale.to_vec(),
        get("head_scale").expect("head scale")
    );
    assert_eq!(
        ehm.hand_scale.to_vec(),
        get("hand_scale").expect("hand scale")
    );

    // On an EHM body (the synthetic model has the real sizes) every channel has a home.
    let mut model = EhmModel::load(Path::new("tests/data/ehm_synthetic.npz")).expect("EHM");
    model.identity = ehm.to_identity();
    let retarget = Retarget::new(&t, &model);
    assert_eq!(retarget.report.lines(), Vec::<String>::new());
    let mut pose = BodyPose::rest(&model);
    let mut posed = PosedBody::default();
    retarget.sample(&t, 0.5 / 25.0, &mut pose);
    model.pose(&pose, &mut posed).expect("pose");
    assert_eq!(posed.nonfinite_inputs, 0);
    assert!(posed.vertices.iter().all(|v| v.is_finite()));
}

#[test]
fn converter_errors_name_the_problem() {
    let dir = std::env::temp_dir().join(format!("guava-convert-err-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let out = dir.join("x.json");
    let run = convert(&[], &out);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("2 videos (clip_a, clip_b); pick one with --video"),
        "{stderr}"
    );
    let run = convert(&["--video", "clip_z"], &out);
    assert!(String::from_utf8_lossy(&run.stderr).contains("no video 'clip_z'"));
    assert!(!out.exists(), "nothing written on error");
}
