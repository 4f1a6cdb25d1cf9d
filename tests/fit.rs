//! Keypoints and single-image fitting: our ONNX path against MediaPipe's TFLite interpreter on the
//! demo portrait (fixture from tools/convert_mediapipe.py), the fit against a synthetic body whose
//! pose and camera are known, and the demo portrait end to end.

use glam::{Vec2, Vec3};
use guava::body::{BodyModel, BodyPose, PosedBody};
use guava::fit::{FitError, fit_keypoints};
use guava::keypoints::{COCO_FROM_MEDIAPIPE, Keypoint, POSE_INPUT, PoseLandmarker};
use guava::onnx::OnnxRuntime;
use guava::reconstruct::{
    DEFAULT_UV_SIZE, MaskSource, Tracked, UvMap, reconstruct_photo_file, synthetic,
};
use std::path::Path;

fn landmarker() -> PoseLandmarker {
    let runtime = OnnxRuntime::load().expect("ONNX Runtime (bash tools/setup.sh installs it)");
    PoseLandmarker::load(runtime).expect("shipped pose model")
}

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(name)
}

#[test]
fn pose_model_matches_mediapipe_on_the_demo_portrait() {
    // The same 8-bit 256² input MediaPipe's interpreter saw, scaled to [0, 1] as its graph does
    // (a [-1, 1] input would silently move every landmark).
    let input: Vec<f32> = image::open(data("tests/data/demo_portrait_256.png"))
        .expect("fixture image")
        .to_rgb8()
        .pixels()
        .flat_map(|p| p.0.map(|c| c as f32 / 255.0))
        .collect();
    assert_eq!(input.len(), POSE_INPUT * POSE_INPUT * 3);
    let fixture: serde_json::Value = serde_json::from_slice(
        &std::fs::read(data("tests/data/pose_landmark_fixture.json")).expect("fixture"),
    )
    .expect("json");
    let expected = fixture["landmarks"].as_array().expect("landmarks");
    let got = landmarker().run(&input, POSE_INPUT as f32).expect("runs");
    let mut worst = 0.0f64;
    for (row, e) in got.landmarks.iter().zip(expected) {
        for k in 0..2 {
            worst = worst.max((row[k] as f64 - e[k].as_f64().expect("number")).abs());
        }
    }
    println!(
        "ONNX Runtime vs TFLite: landmarks within {worst:.2e} px, presence {}",
        got.presence
    );
    // The fixture rounds to 1e-4; the converted graph matched the interpreter to 3e-4 px.
    assert!(worst < 1e-2, "landmarks differ by {worst} px");
    let presence = fixture["presence"].as_f64().expect("presence");
    assert!((got.presence as f64 - presence).abs() < 1e-3);
    // The keypoints land on the person: nose above the shoulders, shoulders apart.
    let k = |n: &str| {
        got.keypoints
            .iter()
            .find(|k| k.name == n)
            .expect("keypoint")
            .pixel
    };
    assert!(k("nose").y < k("left_shoulder").y && k("nose").y < k("right_shoulder").y);
    assert!((k("left_shoulder").x - k("right_shoulder").x).abs() > 60.0);
    // A person's mask: the centre of the chest is in it, the top corner (background) is not.
    assert!(got.mask[150 * POSE_INPUT + 128] > 0.5 && got.mask[5 * POSE_INPUT + 250] < 0.5);
}

fn project_keypoints(
    body: &BodyModel,
    pose: &BodyPose,
    camera: &guava::camera::Camera,
) -> Vec<Keypoint> {
    let mut posed = PosedBody::default();
    body.pose(pose, &mut posed).expect("pose");
    let points = body.landmark_positions(&posed.vertices);
    COCO_FROM_MEDIAPIPE
        .iter()
        .map(|&(name, _)| {
            let l = body
                .landmarks
                .iter()
                .position(|l| l.name == name)
                .expect("landmark");
            let q = camera.project(points[l]);
            Keypoint {
                name,
                pixel: Vec2::new(q.x, q.y),
                confidence: 1.0,
            }
        })
        .collect()
}

#[test]
fn fit_recovers_a_known_pose_and_camera() {
    let body = BodyModel::default_body().expect("body");
    let camera = synthetic::upper_body_camera(&body, 0.0);
    let mut pose = BodyPose::rest(&body);
    for (joint, r) in [
        ("root", Vec3::new(0.0, 0.25, 0.0)),
        ("upperarm01.L", Vec3::new(0.0, 0.0, 0.6)),
        ("lowerarm01.L", Vec3::new(0.0, -0.9, 0.0)),
        ("upperarm01.R", Vec3::new(0.3, 0.0, -0.3)),
        ("head", Vec3::new(0.2, 0.3, 0.0)),
    ] {
        pose.set_rotation(&body, joint, r).expect("joint");
    }
    let keypoints = project_keypoints(&body, &pose, &camera);
    let started = std::time::Instant::now();
    let (view, report) = fit_keypoints(&body, &keypoints, 512).expect("fit");
    println!("{report:?} in {:?}", started.elapsed());
    // Reprojection: the fit explains the keypoints to a few pixels; the prior (25 px per radian
    // of joint rotation) trades some of it for a pose near rest (2.1 px measured).
    assert!(report.rms_px < 3.0, "{report:?}");
    // The camera: the fit's distance and offset against the truth, through the body's root.
    let truth = camera.view_from_world.transform_point3(body.joints[0].rest);
    let fitted = view
        .camera
        .view_from_world
        .transform_point3(body.joints[0].rest);
    let rel_depth = (fitted.z - truth.z).abs() / truth.z;
    println!(
        "root in camera space: fitted {fitted}, truth {truth} (depth off by {:.2}%)",
        100.0 * rel_depth
    );
    assert!(rel_depth < 0.05 && (fitted.truncate() - truth.truncate()).length() < 0.05);
    // Arms and head in camera space: across the view within 3 cm of the truth. Along the view
    // a limb's depth is not determined by 2D keypoints (a forearm bent towards or away from the
    // camera projects alike), so that error is printed, not bounded.
    let in_camera = |pose: &BodyPose, cam: &guava::camera::Camera| {
        let mut posed = PosedBody::default();
        body.pose(pose, &mut posed).expect("pose");
        body.landmark_positions(&posed.vertices)
            .into_iter()
            .map(|p| cam.view_from_world.transform_point3(p))
            .collect::<Vec<_>>()
    };
    let (a, b) = (
        in_camera(&pose, &camera),
        in_camera(&view.pose, &view.camera),
    );
    for name in [
        "left_elbow",
        "left_wrist",
        "right_elbow",
        "right_wrist",
        "nose",
    ] {
        let l = body
            .landmarks
            .iter()
            .position(|l| l.name == name)
            .expect("landmark");
        let across = (a[l].truncate() - b[l].truncate()).length();
        println!(
            "{name}: {across:.3} m across the view, {:.3} m along it",
            (a[l].z - b[l].z).abs()
        );
        assert!(across < 0.03, "{name} off by {across} m across the view");
    }
}

#[test]
fn too_few_keypoints_is_a_clear_error() {
    let body = BodyModel::default_body().expect("body");
    let camera = synthetic::upper_body_camera(&body, 0.0);
    let mut keypoints = project_keypoints(&body, &BodyPose::rest(&body), &camera);
    for k in &mut keypoints {
        if k.name != "nose" && k.name != "left_shoulder" {
            k.confidence = 0.1;
        }
    }
    let e = fit_keypoints(&body, &keypoints, 512).expect_err("too few");
    assert!(
        matches!(e, FitError::TooFewKeypoints { found: 2, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("nose, left_shoulder"), "{e}");
}

#[test]
fn the_demo_portrait_fits_and_reconstructs() {
    let body = BodyModel::default_body().expect("body");
    let uv = UvMap::for_body(&body, DEFAULT_UV_SIZE);
    let mut model = landmarker();
    let photo = data("assets/demo_portrait.png");
    let (avatar, report, view) = reconstruct_photo_file(
        &body,
        &uv,
        &photo,
        Tracked::Fit,
        Some(&mut model),
        &mut |_| true,
    )
    .expect("reconstructs");
    let fit = report.fit.clone().expect("fitted");
    println!("{fit:?}; {report:?}");
    assert!(fit.keypoints_used >= 9 && fit.rms_px < 8.0, "{fit:?}");
    assert_eq!(report.mask, MaskSource::Segmentation);
    assert!(report.observed > 20_000, "{report:?}");
    avatar.validate().expect("finite avatar");
    // The shipped tracking is what the fit gives (guava fit wrote it).
    let shipped =
        guava::tracking::Tracking::load(&data("assets/demo_portrait.json")).expect("shipped");
    let camera = shipped.frames[0].camera.expect("camera");
    for r in 0..3 {
        let row = view.camera.view_from_world.row(r);
        for c in 0..4 {
            assert!(
                (row[c] - camera.w2c[r][c]).abs() < 1e-3,
                "w2c[{r}][{c}]: {} vs {}",
                row[c],
                camera.w2c[r][c]
            );
        }
    }
}
