//! The default body asset and the posing API: known answers, invariants, extremes, bad assets.

use glam::{Affine3A, Mat3, Vec3};
use guava::body::{
    BodyModel, BodyPose, PoseError, PosedBody, SMPLX_JOINTS, TargetGroup, TriangleFrame,
    smplx_to_default, triangle_frames,
};

fn body() -> BodyModel {
    BodyModel::default_body().expect("the embedded default body loads")
}

fn posed(model: &BodyModel, pose: &BodyPose) -> PosedBody {
    let mut out = PosedBody::default();
    model
        .pose(pose, &mut out)
        .expect("pose has the model's lengths");
    out
}

fn max_dist(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| x.distance(*y))
        .fold(0.0, f32::max)
}

fn assert_finite(p: &PosedBody) {
    assert!(
        p.vertices.iter().all(|v| v.is_finite()),
        "posed vertices must be finite"
    );
    assert!(
        p.skin.iter().all(|a| a.is_finite()),
        "skin transforms must be finite"
    );
    assert!(
        p.joints.iter().all(|a| a.is_finite()),
        "joint transforms must be finite"
    );
}

#[test]
fn default_body_has_the_documented_content() {
    let m = body();
    assert_eq!(m.vertices.len(), 15_066);
    assert_eq!(m.triangles.len(), 27_676);
    assert_eq!(m.joints.len(), 77);
    assert_eq!(m.targets_in(TargetGroup::Expression).count(), 52);
    // Six phenotypes × two ends, and the derived head size.
    assert_eq!(m.targets_in(TargetGroup::Shape).count(), 13);
    for name in [
        "root",
        "jaw",
        "eye.L",
        "eye.R",
        "neck01",
        "head",
        "wrist.L",
        "finger1-3.R",
        "finger5-1.L",
    ] {
        assert!(m.joint_index(name).is_some(), "joint {name}");
    }
    for name in [
        "jawOpen",
        "eyeBlinkLeft",
        "mouthSmileRight",
        "tongueOut",
        "gender_max",
        "weight_min",
    ] {
        assert!(m.target_index(name).is_some(), "target {name}");
    }
    // Metres, y up, facing +z: a standing adult 1.5–1.9 m tall, eyes in front of the head joint.
    let (lo, hi) = m
        .vertices
        .iter()
        .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
    assert!(
        (1.5..1.9).contains(&(hi.y - lo.y)),
        "height {}",
        hi.y - lo.y
    );
    let joint = |n: &str| m.joints[m.joint_index(n).expect("joint")].rest;
    assert!(joint("eye.L").z > joint("head").z && joint("eye.L").x > 0.0 && joint("eye.R").x < 0.0);
    assert!(joint("head").y > joint("neck01").y && joint("neck01").y > joint("root").y);
    // The jaw opens downwards.
    let jaw = &m.targets[m.target_index("jawOpen").expect("jawOpen")];
    let mean_dy: f32 = jaw.deltas.iter().map(|d| d.y).sum::<f32>() / jaw.deltas.len() as f32;
    assert!(
        mean_dy < 0.0,
        "jawOpen moves vertices down on average ({mean_dy})"
    );
    // Weld ids stay inside the source mesh and seams are real duplicates.
    for (i, j) in (0..m.vertices.len()).zip(1..m.vertices.len()) {
        if m.weld[i] == m.weld[j] {
            assert_eq!(m.vertices[i], m.vertices[j]);
        }
    }
}

#[test]
fn skin_weights_sum_to_one_and_parents_come_first() {
    let m = body();
    for (v, w) in m.skin_weights.iter().enumerate() {
        let sum: f32 = w.iter().sum();
        assert!((sum - 1.0).abs() < 1e-5, "vertex {v}: {sum}");
    }
    for (j, joint) in m.joints.iter().enumerate() {
        assert_eq!(joint.parent.is_none(), j == 0);
        assert!(joint.parent.is_none_or(|p| p < j));
    }
}

#[test]
fn rest_pose_returns_the_template() {
    let m = body();
    let p = posed(&m, &BodyPose::rest(&m));
    // Blended identity transforms: exact up to the f32 rounding of weights summing to 1.
    assert!(
        max_dist(&p.vertices, &m.vertices) < 1e-6,
        "{}",
        max_dist(&p.vertices, &m.vertices)
    );
    for a in &p.skin {
        assert!(a.abs_diff_eq(Affine3A::IDENTITY, 1e-5));
    }
    assert_eq!(p.nonfinite_inputs, 0);
}

#[test]
fn global_rotation_and_translation_move_everything_rigidly() {
    let m = body();
    let mut pose = BodyPose::rest(&m);
    let axis_angle = Vec3::new(0.3, -1.1, 0.7);
    let t = Vec3::new(0.1, -0.2, 2.0);
    pose.set_rotation(&m, "root", axis_angle).expect("root");
    pose.translation = t;
    let p = posed(&m, &pose);
    let r = Mat3::from_axis_angle(axis_angle.normalize(), axis_angle.length());
    let pivot = m.joints[0].rest;
    let expected: Vec<Vec3> = m
        .vertices
        .iter()
        .map(|v| r * (*v - pivot) + pivot + t)
        .collect();
    assert!(
        max_dist(&p.vertices, &expected) < 1e-5,
        "{}",
        max_dist(&p.vertices, &expected)
    );
    for a in &p.skin {
        assert!(Mat3::from(a.matrix3).abs_diff_eq(r, 1e-5));
    }
}

#[test]
fn a_joint_rotation_moves_its_subtree_about_the_joint() {
    let m = body();
    let elbow = m.joint_index("lowerarm01.L").expect("elbow");
    let mut pose = BodyPose::rest(&m);
    pose.rotations[elbow] = Vec3::new(0.0, 0.0, 1.2);
    let p = posed(&m, &pose);
    let pivot = m.joints[elbow].rest;
    // Vertices skinned only to the elbow's descendants turn rigidly about it; the rest stay.
    let descendant = |mut j: usize| loop {
        if j == elbow {
            return true;
        }
        match m.joints[j].parent {
            Some(parent) => j = parent,
            None => return false,
        }
    };
    let r = Mat3::from_rotation_z(1.2);
    let (mut moved, mut still) = (0, 0);
    for v in 0..m.vertices.len() {
        let influences: Vec<usize> = (0..8)
            .filter(|&i| m.skin_weights[v][i] > 0.0)
            .map(|i| m.skin_joints[v][i] as usize)
            .collect();
        if influences.iter().all(|&j| descendant(j)) {
            let expected = r * (m.vertices[v] - pivot) + pivot;
            assert!(p.vertices[v].distance(expected) < 1e-5);
            moved += 1;
        } else if influences.iter().all(|&j| !descendant(j)) {
            assert!(p.vertices[v].distance(m.vertices[v]) < 1e-6);
            still += 1;
        }
    }
    assert!(moved > 500 && still > 5000, "moved {moved}, still {still}");
    // The joint's own world frame sits at the (unmoved) elbow with the given rotation.
    assert!(Vec3::from(p.joints[elbow].translation).distance(pivot) < 1e-6);
}

#[test]
fn morph_targets_are_linear() {
    let m = body();
    for name in ["jawOpen", "eyeBlinkLeft", "gender_max", "height_min"] {
        let t = m.target_index(name).expect("target");
        let at = |c: f32| {
            let mut pose = BodyPose::rest(&m);
            pose.coefficients[t] = c;
            posed(&m, &pose)
        };
        let (zero, one, a) = (at(0.0), at(1.0), at(-2.5));
        for v in 0..m.vertices.len() {
            let expected = zero.vertices[v] + -2.5 * (one.vertices[v] - zero.vertices[v]);
            assert!(a.vertices[v].distance(expected) < 1e-5, "{name} vertex {v}");
        }
        for j in 0..m.joints.len() {
            let expected = zero.rest_joints[j] + -2.5 * (one.rest_joints[j] - zero.rest_joints[j]);
            assert!(
                a.rest_joints[j].distance(expected) < 1e-5,
                "{name} joint {j}"
            );
        }
        assert!(
            max_dist(&one.vertices, &zero.vertices) > 1e-3,
            "{name} moves something"
        );
    }
}

#[test]
fn shape_targets_move_the_joints_with_the_mesh() {
    let m = body();
    let mut pose = BodyPose::rest(&m);
    pose.set_coefficient(&m, "height_max", 1.0).expect("target");
    let p = posed(&m, &pose);
    let head = m.joint_index("head").expect("head");
    assert!(
        p.rest_joints[head].y - m.joints[head].rest.y > 0.01,
        "a taller body has a higher head joint"
    );
}

fn frame_of(v: [Vec3; 3]) -> TriangleFrame {
    let mut out = Vec::new();
    triangle_frames(&v, &[[0, 1, 2]], &mut out);
    out[0]
}

#[test]
fn triangle_frames_match_the_reference_formula() {
    // Analytic: first edge along x (length 2), apex at height 1 along y.
    let f = frame_of([
        Vec3::ZERO,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.5, 1.0, 0.0),
    ]);
    assert!(
        f.rotation
            .abs_diff_eq(Mat3::from_cols(Vec3::X, Vec3::Z, -Vec3::Y), 1e-6),
        "{:?}",
        f.rotation
    );
    assert!((f.scale - 1.5).abs() < 1e-6);
    // Every frame of the posed default body is a rotation (orthonormal, det +1).
    let m = body();
    let mut pose = BodyPose::rest(&m);
    pose.set_rotation(&m, "neck01", Vec3::new(0.4, 0.8, -0.2))
        .expect("neck");
    let p = posed(&m, &pose);
    let mut frames = Vec::new();
    triangle_frames(&p.vertices, &m.triangles, &mut frames);
    let mut checked = 0;
    for (t, f) in frames.iter().enumerate() {
        assert!(
            f.rotation.is_finite() && f.scale.is_finite(),
            "triangle {t}"
        );
        if f.scale > 1e-5 {
            let r = f.rotation;
            assert!(
                (r.transpose() * r).abs_diff_eq(Mat3::IDENTITY, 1e-4),
                "triangle {t}"
            );
            assert!((r.determinant() - 1.0).abs() < 1e-4, "triangle {t}");
            checked += 1;
        }
    }
    assert!(checked > 27_000, "{checked}");
}

#[test]
fn degenerate_triangles_give_finite_frames() {
    let p = Vec3::new(0.3, 0.2, 0.1);
    for tri in [
        [p, p, p],
        [Vec3::ZERO, Vec3::X, 2.0 * Vec3::X],
        [Vec3::ZERO, Vec3::ZERO, Vec3::Y],
    ] {
        let f = frame_of(tri);
        assert!(
            f.rotation.is_finite() && f.scale.is_finite(),
            "{tri:?} → {f:?}"
        );
    }
}

#[test]
fn extreme_and_invalid_inputs_stay_finite() {
    let m = body();
    let extremes = [
        Vec3::new(std::f32::consts::PI, 0.0, 0.0),
        Vec3::new(-std::f32::consts::PI, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 10.0 * std::f32::consts::PI),
        Vec3::new(0.0, std::f32::consts::FRAC_PI_2, 0.0), // gimbal configuration for Euler xyz
        Vec3::splat(1e6),
        Vec3::splat(1e-30),
    ];
    for (k, e) in extremes.iter().enumerate() {
        let mut pose = BodyPose::rest(&m);
        pose.rotations.iter_mut().for_each(|r| *r = *e);
        for (c, t) in pose.coefficients.iter_mut().zip(&m.targets) {
            *c = if k % 2 == 0 {
                10.0 * t.range[1]
            } else {
                -10.0 * t.range[1]
            };
        }
        let p = posed(&m, &pose);
        assert_finite(&p);
        assert_eq!(p.nonfinite_inputs, 0);
    }
    let mut pose = BodyPose::rest(&m);
    pose.rotations[3] = Vec3::new(f32::NAN, 0.0, 0.0);
    pose.rotations[5] = Vec3::splat(f32::MAX); // finite, but its length overflows
    pose.coefficients[0] = f32::INFINITY;
    pose.translation = Vec3::new(0.0, f32::NEG_INFINITY, 0.0);
    let p = posed(&m, &pose);
    assert_finite(&p);
    assert_eq!(p.nonfinite_inputs, 4);
    assert!(
        max_dist(&p.vertices, &m.vertices) < 1e-6,
        "invalid values are treated as zero"
    );
}

#[test]
fn pose_errors_name_the_problem() {
    let m = body();
    let mut pose = BodyPose::rest(&m);
    assert_eq!(
        pose.set_rotation(&m, "tail", Vec3::X),
        Err(PoseError::UnknownJoint("tail".into()))
    );
    assert_eq!(
        pose.set_coefficient(&m, "smirk", 1.0),
        Err(PoseError::UnknownParameter("smirk".into()))
    );
    pose.rotations.pop();
    let err = m
        .pose(&pose, &mut PosedBody::default())
        .expect_err("wrong length");
    assert_eq!(err.to_string(), "pose has 76 rotations for a body with 77");
}

#[test]
fn landmarks_and_parts_sit_where_anatomy_puts_them() {
    let model = body();
    let names: Vec<&str> = model.landmarks.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names.len(), 23, "COCO-WholeBody body + feet: {names:?}");
    let rest = model.landmark_positions(&model.vertices);
    let at = |name: &str| rest[names.iter().position(|n| *n == name).expect(name)];
    for (name, p) in names.iter().zip(&rest) {
        if name.starts_with("left_") {
            assert!(p.x > 0.01, "{name} {p} should be on the body's left (+x)");
        } else if name.starts_with("right_") {
            assert!(p.x < -0.01, "{name} {p} should be on the right");
        }
    }
    let heights = [
        "left_eye",
        "nose",
        "left_shoulder",
        "left_elbow",
        "left_hip",
        "left_knee",
    ];
    for pair in heights.windows(2) {
        assert!(
            at(pair[0]).y > at(pair[1]).y,
            "{} above {}",
            pair[0],
            pair[1]
        );
    }
    let wrist = model.joints[model.joint_index("wrist.L").expect("wrist")].rest;
    assert!(
        at("left_wrist").distance(wrist) < 0.05,
        "left wrist keypoint near the wrist joint"
    );

    // Landmarks are carried by the posed mesh.
    let mut pose = BodyPose::rest(&model);
    pose.set_rotation(&model, "lowerarm01.L", Vec3::new(0.0, 0.0, 1.2))
        .expect("joint");
    let posed = posed(&model, &pose);
    let moved = model.landmark_positions(&posed.vertices);
    let wrist_index = names
        .iter()
        .position(|n| *n == "left_wrist")
        .expect("wrist");
    assert!(moved[wrist_index].distance(rest[wrist_index]) > 0.05);
    assert!(moved[0].distance(rest[0]) < 1e-6, "the nose stays");

    assert_eq!(model.vertex_parts.len(), model.vertices.len());
    let part = |name: &str| model.part_names.iter().position(|n| n == name).expect(name) as u8;
    let neck = model.joints[model.joint_index("neck01").expect("neck")].rest;
    for (v, &p) in model.vertices.iter().zip(&model.vertex_parts) {
        if p == part("hand.L") {
            assert!(v.x > 0.3, "left-hand vertex {v}");
        } else if p == part("hand.R") {
            assert!(v.x < -0.3, "right-hand vertex {v}");
        } else if p == part("head") {
            assert!(v.y > neck.y, "head vertex {v} below the neck joint");
        }
    }
    for (i, name) in model.part_names.iter().enumerate() {
        assert!(
            model.vertex_parts.contains(&(i as u8)),
            "part {name} has vertices"
        );
    }
}

#[test]
fn smplx_names_map_onto_the_default_rig() {
    let m = body();
    let mut unmapped = Vec::new();
    for name in SMPLX_JOINTS {
        match smplx_to_default(name) {
            Some(joint) => assert!(
                m.joint_index(&joint).is_some(),
                "{name} → {joint} is not a joint"
            ),
            None => unmapped.push(name),
        }
    }
    assert_eq!(unmapped, ["left_foot", "right_foot"]);
    assert_eq!(
        smplx_to_default("left_thumb2").as_deref(),
        Some("finger1-2.L")
    );
    assert_eq!(
        smplx_to_default("right_pinky3").as_deref(),
        Some("finger5-3.R")
    );
}

/// The GLB with its JSON chunk edited by `edit`, the BIN chunk kept.
fn edited_glb(edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let glb = guava::body::DEFAULT_BODY_GLB;
    let json_len = u32::from_le_bytes(glb[12..16].try_into().expect("4 bytes")) as usize;
    let mut json: serde_json::Value =
        serde_json::from_slice(&glb[20..20 + json_len]).expect("json");
    edit(&mut json);
    let mut js = serde_json::to_vec(&json).expect("json");
    while !js.len().is_multiple_of(4) {
        js.push(b' ');
    }
    let bin = &glb[20 + json_len..];
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + js.len() + bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(js.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&js);
    out.extend_from_slice(bin);
    out
}

fn load_error(bytes: &[u8]) -> String {
    match BodyModel::from_glb(bytes, "bad.glb") {
        Ok(_) => panic!("a malformed asset loaded"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn malformed_assets_are_errors_naming_file_and_problem() {
    let glb = guava::body::DEFAULT_BODY_GLB;
    let extras = "/meshes/0/extras/guava_body";
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (b"not a glb".to_vec(), "not a valid glTF"),
        (glb[..glb.len() / 2].to_vec(), "bad.glb: "),
        (
            edited_glb(|j| j["meshes"][0]["extras"] = serde_json::Value::Null),
            "guava_body is missing",
        ),
        (
            edited_glb(|j| j.pointer_mut(extras).expect("x")["format"] = 7.into()),
            "format is 7",
        ),
        (
            edited_glb(|j| {
                j.pointer_mut(extras).expect("x")["targets"][3]["group"] = "mood".into()
            }),
            "unknown group \"mood\"",
        ),
        (
            edited_glb(|j| {
                let deltas = j.pointer_mut(extras).expect("x")["targets"][0]["joint_deltas"]
                    .as_array_mut()
                    .expect("array");
                deltas.pop();
            }),
            "76 joint deltas for 77 joints",
        ),
        (
            edited_glb(|j| {
                let attrs = &mut j["meshes"][0]["primitives"][0]["attributes"];
                attrs["WEIGHTS_1"] = attrs["TEXCOORD_0"].clone();
            }),
            "Weights(1)",
        ),
        (
            edited_glb(|j| {
                let attrs = j["meshes"][0]["primitives"][0]["attributes"]
                    .as_object_mut()
                    .expect("attrs");
                attrs.remove("JOINTS_1");
            }),
            "Joints(1)",
        ),
        (
            edited_glb(|j| j["skins"][0]["inverseBindMatrices"] = serde_json::Value::Null),
            "inverseBindMatrices",
        ),
        (
            edited_glb(|j| j["buffers"][0]["byteLength"] = (glb.len() * 2).into()),
            "BIN chunk",
        ),
        (
            edited_glb(|j| {
                let counts = &mut j.pointer_mut(extras).expect("x")["landmarks"]["counts"];
                let (first, second) = (
                    counts[0].as_u64().expect("n"),
                    counts[1].as_u64().expect("n"),
                );
                counts[0] = (first / 2).into();
                counts[1] = (second + first - first / 2).into();
            }),
            "landmark nose: weights sum to",
        ),
        (
            edited_glb(|j| {
                let body = j.pointer_mut(extras).expect("x");
                body["landmarks"]["weights"] = body["weld"].clone();
            }),
            "landmarks.weights must be a SCALAR F32 accessor",
        ),
        (
            edited_glb(|j| {
                let names = j.pointer_mut(extras).expect("x")["parts"]["names"]
                    .as_array_mut()
                    .expect("names");
                names.truncate(1);
            }),
            "but only 1 parts are named",
        ),
    ];
    for (bytes, expected) in cases {
        let message = load_error(&bytes);
        assert!(message.starts_with("bad.glb: "), "{message}");
        assert!(
            message.contains(expected),
            "expected {expected:?} in {message:?}"
        );
    }
}

#[test]
fn skin_weight_and_index_corruption_is_caught() {
    // Point WEIGHTS_0 at a copy whose first vertex sums to 2: the writer's accessor layout is
    // reused by duplicating WEIGHTS_1 into WEIGHTS_0 (weights that no longer sum to one).
    let bytes = edited_glb(|j| {
        let attrs = &mut j["meshes"][0]["primitives"][0]["attributes"];
        attrs["WEIGHTS_0"] = attrs["WEIGHTS_1"].clone();
    });
    assert!(
        load_error(&bytes).contains("sum to"),
        "{}",
        load_error(&bytes)
    );
}

/// The fit's sparse posing gives what full posing gives, for landmarks and joints alike, with
/// shape and expression morphs and rotations on every joint.
#[test]
fn posing_a_few_points_matches_posing_the_mesh() {
    let body = BodyModel::default_body().expect("body");
    let mut pose = BodyPose::rest(&body);
    pose.translation = Vec3::new(0.1, -0.2, 0.3);
    for (j, r) in pose.rotations.iter_mut().enumerate() {
        let t = j as f32;
        *r = 0.3 * Vec3::new((1.3 * t).sin(), (0.7 * t).cos(), (2.1 * t).sin());
    }
    for (i, c) in pose.coefficients.iter_mut().enumerate() {
        *c = 0.5 * ((i as f32) * 0.37).sin();
    }
    let mut posed = PosedBody::default();
    body.pose(&pose, &mut posed).expect("pose");
    let expected = body.landmark_positions(&posed.vertices);
    let mut poser = guava::body::PointPoser::new(&body, &body.landmarks);
    let (mut points, mut joints) = (Vec::new(), Vec::new());
    poser
        .pose(&body, &pose, &mut points, &mut joints)
        .expect("pose points");
    assert_eq!(points.len(), body.landmarks.len());
    // The same sums regrouped by joint: equal up to f32 rounding on metre-sized values.
    let worst = points
        .iter()
        .zip(&expected)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0f32, f32::max);
    println!("sparse vs full posing: {worst:.1e} m");
    assert!(worst < 1e-5, "{worst} m");
    for (a, b) in joints.iter().zip(&posed.joints) {
        assert!(a.distance(Vec3::from(b.translation)) < 1e-6);
    }
}

/// The derived head-size target scales the head about the head joint (vertices and joints
/// skinned only to the head move exactly by the scale), leaves what the head's joints do not
/// skin alone, and blends the neck in between.
#[test]
fn head_size_scales_the_head_about_its_joint() {
    let m = body();
    let t = m
        .target_index(guava::body::HEAD_SIZE)
        .expect("derived target");
    let mut pose = BodyPose::rest(&m);
    pose.coefficients[t] = 0.25;
    let p = posed(&m, &pose);
    let head = m.joint_index("head").expect("head");
    let centre = m.joints[head].rest;
    let in_head = |j: usize| {
        let mut k = Some(j);
        while let Some(i) = k {
            if i == head {
                return true;
            }
            k = m.joints[i].parent;
        }
        false
    };
    let (mut whole, mut untouched, mut blended) = (0, 0, 0);
    for (v, (js, ws)) in m.skin_joints.iter().zip(&m.skin_weights).enumerate() {
        let w: f32 = js
            .iter()
            .zip(ws)
            .filter(|(j, _)| in_head(**j as usize))
            .map(|(_, w)| w)
            .sum();
        let expected = m.vertices[v] + 0.25 * w * (m.vertices[v] - centre);
        assert!(p.vertices[v].distance(expected) < 1e-5, "vertex {v}");
        if w > 0.999 {
            whole += 1;
        } else if w < 1e-6 {
            untouched += 1;
            assert!(p.vertices[v].distance(m.vertices[v]) < 1e-6);
        } else {
            blended += 1;
        }
    }
    println!("head vertices {whole}, neck blend {blended}, unmoved {untouched}");
    assert!(whole > 1000 && blended > 10 && untouched > 9_000);
    let jaw = m.joint_index("jaw").expect("jaw");
    let moved = Vec3::from(p.joints[jaw].translation);
    assert!(moved.distance(centre + 1.25 * (m.joints[jaw].rest - centre)) < 1e-5);
}
