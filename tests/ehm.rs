//! EHM (SMPL-X + FLAME head) against the authors' reference forward, on a synthetic model with the
//! real array names and shapes (`tools/make_ehm_fixture.py` wrote both fixtures with PyTorch).

use std::io::{Cursor, Read, Write};
use std::path::Path;

use glam::{Affine3A, Vec3};
use guava::body::{
    BodyPose, EhmExtras, EhmIdentity, EhmModel, EhmParams, Posable, PosedBody, triangle_frames,
};
use guava::npz::Npz;

use crate::npz_writer::{f32_bytes, npy};

const MODEL: &str = "tests/data/ehm_synthetic.npz";
const PARITY: &str = "tests/data/ehm_parity.npz";
/// The bound. The reference runs in float32 with its own summation order; our f32 sums
/// differ by rounding only (~1e-7 m at body scale, ~1e-6 m for the extreme case).
const TOLERANCE_M: f32 = 1e-5;

fn model() -> EhmModel {
    EhmModel::load(Path::new(MODEL)).expect("synthetic EHM loads")
}

/// One case's slice of a stacked fixture array.
fn case<'a>(npz: &'a Npz, name: &str, k: usize) -> &'a [f32] {
    let rank = npz.shape(name).expect(name).len();
    let (data, shape) = npz.f32s(name, &vec![None; rank]).expect(name);
    let per_case = data.len() / shape[0];
    &data[k * per_case..(k + 1) * per_case]
}

fn vec3s(data: &[f32]) -> Vec<Vec3> {
    data.chunks_exact(3).map(Vec3::from_slice).collect()
}

fn params(npz: &Npz, k: usize) -> EhmParams {
    let v3 = |name: &str| Vec3::from_slice(case(npz, name, k));
    let eyes = vec3s(case(npz, "flame_eye_pose_params", k));
    let lids = case(npz, "flame_eyelid_params", k);
    EhmParams {
        shape: case(npz, "body_shape", k).to_vec(),
        expression: case(npz, "body_exp", k).to_vec(),
        global_pose: v3("body_global_pose"),
        body_pose: vec3s(case(npz, "body_body_pose", k)),
        left_hand_pose: vec3s(case(npz, "body_left_hand_pose", k)),
        right_hand_pose: vec3s(case(npz, "body_right_hand_pose", k)),
        flame_shape: case(npz, "flame_shape_params", k).to_vec(),
        flame_expression: case(npz, "flame_expression_params", k).to_vec(),
        jaw: v3("flame_jaw_params"),
        eyes: [eyes[0], eyes[1]],
        eyelids: [lids[0], lids[1]],
        identity: EhmIdentity {
            joints_offset: vec3s(case(npz, "body_joints_offset", k)),
            head_scale: v3("body_head_scale"),
            hand_scale: v3("body_hand_scale"),
        },
        translation: Vec3::ZERO,
    }
}

/// Largest difference between our affine and the top 3×4 of a row-major 4×4.
fn affine_error(ours: &Affine3A, reference: &[f32]) -> f32 {
    let m = ours.matrix3;
    let t = ours.translation;
    let mut worst = 0.0f32;
    for row in 0..3 {
        for col in 0..3 {
            worst = worst.max((m.col(col)[row] - reference[4 * row + col]).abs());
        }
        worst = worst.max((t[row] - reference[4 * row + 3]).abs());
    }
    worst
}

fn max_error(ours: &[Vec3], reference: &[f32]) -> f32 {
    assert_eq!(ours.len() * 3, reference.len());
    ours.iter()
        .zip(vec3s(reference))
        .map(|(a, b)| (*a - b).abs().max_element())
        .fold(0.0, f32::max)
}

#[test]
fn forward_matches_the_reference_ehm() {
    let model = model();
    let npz = Npz::open(Path::new(PARITY)).expect("fixture");
    assert_eq!(model.body.template.len(), 10_595, "SMPL-X with teeth");
    assert_eq!(model.head.template.len(), 5_143, "FLAME with teeth");
    let (stride, _) = npz
        .indices("out_ver_transform_stride", &[Some(1)], 1..100)
        .expect("stride");
    let stride = stride[0] as usize;
    let names = ["rest", "random", "extreme"];
    let mut out = PosedBody::default();
    let mut extras = EhmExtras::default();
    for (k, name) in names.iter().enumerate() {
        model.forward(&params(&npz, k), &mut out, &mut extras);
        assert_eq!(out.nonfinite_inputs, 0);
        let vertices = max_error(&out.vertices, case(&npz, "out_vertices", k));
        let rest = max_error(&out.rest_joints, case(&npz, "out_joints", k));
        let posed: Vec<Vec3> = out.joints.iter().map(|j| j.translation.into()).collect();
        let posed = max_error(&posed, case(&npz, "out_joints_transform", k));
        let placements = extras
            .placements
            .iter()
            .zip(case(&npz, "out_joint_transform_mat", k).chunks_exact(16))
            .map(|(a, r)| affine_error(a, r))
            .fold(0.0, f32::max);
        let skins = case(&npz, "out_ver_transform_mat", k);
        let skin = out
            .skin
            .iter()
            .step_by(stride)
            .zip(skins.chunks_exact(16))
            .map(|(a, r)| affine_error(a, r))
            .fold(0.0, f32::max);
        assert_eq!(skins.len() / 16, out.skin.len().div_ceil(stride));
        println!(
            "{name}: vertices {vertices:.2e} m, rest joints {rest:.2e}, posed joints {posed:.2e}, \
             joint transforms {placements:.2e}, vertex transforms {skin:.2e}"
        );
        for (what, err) in [
            ("vertices", vertices),
            ("rest joints", rest),
            ("posed joints", posed),
            ("joint transforms", placements),
            ("vertex transforms", skin),
        ] {
            assert!(err <= TOLERANCE_M, "{name}: {what} differ by {err:e}");
        }
    }
}

#[test]
fn named_pose_drives_the_same_forward() {
    let mut model = model();
    let npz = Npz::open(Path::new(PARITY)).expect("fixture");
    let p = params(&npz, 1);
    model.identity = p.identity.clone();
    let mut pose = BodyPose::rest(&model);
    pose.set_rotation(&model, "pelvis", p.global_pose)
        .expect("pelvis");
    pose.set_rotation(&model, "jaw", p.jaw).expect("jaw");
    pose.set_rotation(&model, "left_eye_smplhf", p.eyes[0])
        .expect("eye");
    pose.set_rotation(&model, "right_eye_smplhf", p.eyes[1])
        .expect("eye");
    for (i, &r) in p.body_pose.iter().enumerate() {
        pose.rotations[1 + i] = r;
    }
    for (i, (&l, &r)) in p.left_hand_pose.iter().zip(&p.right_hand_pose).enumerate() {
        pose.rotations[25 + i] = l;
        pose.rotations[40 + i] = r;
    }
    let groups = [
        ("shape_", &p.shape),
        ("expression_", &p.expression),
        ("flame_shape_", &p.flame_shape),
        ("flame_expression_", &p.flame_expression),
    ];
    for (prefix, values) in groups {
        for (i, &v) in values.iter().enumerate() {
            pose.set_coefficient(&model, &format!("{prefix}{i:03}"), v)
                .expect("coefficient");
        }
    }
    pose.set_coefficient(&model, "eyelid_left", p.eyelids[0])
        .expect("eyelid");
    pose.set_coefficient(&model, "eyelid_right", p.eyelids[1])
        .expect("eyelid");
    pose.translation = Vec3::new(0.5, -1.0, 2.0);

    let mut named = PosedBody::default();
    Posable::pose(&model, &pose, &mut named).expect("pose");
    let mut direct = PosedBody::default();
    model.forward(&p, &mut direct, &mut EhmExtras::default());
    for (a, b) in named.vertices.iter().zip(&direct.vertices) {
        assert!((*a - *b - pose.translation).abs().max_element() < 1e-6);
    }
    for (a, b) in named.skin.iter().zip(&direct.skin) {
        assert_eq!(a.matrix3, b.matrix3);
        assert!(
            (a.translation - b.translation - glam::Vec3A::from(pose.translation))
                .abs()
                .max_element()
                < 1e-6,
            "translation applies to the skinning transforms"
        );
    }
}

#[test]
fn posed_ehm_frames_are_rotations_and_nan_inputs_are_counted() {
    let model = model();
    let mut p = EhmParams::rest(&model);
    p.jaw = Vec3::new(f32::NAN, 0.0, 0.0);
    p.body_pose[3] = Vec3::new(0.0, f32::INFINITY, 0.0);
    p.shape[0] = f32::NAN;
    p.identity.head_scale = Vec3::new(1.0, f32::NAN, 1.0);
    p.eyelids = [f32::NEG_INFINITY, 0.5];
    let mut out = PosedBody::default();
    model.forward(&p, &mut out, &mut EhmExtras::default());
    assert_eq!(out.nonfinite_inputs, 5);
    assert!(out.vertices.iter().all(|v| v.is_finite()));
    assert!(out.skin.iter().all(|s| s.is_finite()));

    let mut frames = Vec::new();
    triangle_frames(&out.vertices, model.triangles(), &mut frames);
    let mut checked = 0;
    for f in frames.iter().filter(|f| f.scale > 1e-6) {
        let r = f.rotation;
        assert!((r.transpose() * r).abs_diff_eq(glam::Mat3::IDENTITY, 1e-4));
        assert!((r.determinant() - 1.0).abs() < 1e-4);
        checked += 1;
    }
    assert!(checked > 20_000, "{checked} non-degenerate triangles");
}

/// The synthetic model's archive with one array replaced (or removed when `npy` is None).
fn with_array(name: &str, npy: Option<Vec<u8>>) -> Vec<u8> {
    let bytes = std::fs::read(MODEL).expect("model bytes");
    let mut archive = zip::ZipArchive::new(Cursor::new(bytes)).expect("zip");
    let mut out = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    for i in 0..archive.len() {
        let mut entry = archive.by_index(i).expect("entry");
        let entry_name = entry.name().expect("name").to_string();
        let mut data = Vec::new();
        entry.read_to_end(&mut data).expect("read");
        if entry_name == format!("{name}.npy") {
            match &npy {
                Some(replacement) => data = replacement.clone(),
                None => continue,
            }
        }
        out.start_file(entry_name, options).expect("start");
        out.write_all(&data).expect("write");
    }
    out.finish().expect("finish").into_inner()
}

fn i32_bytes(values: &[i32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn load_error(bytes: Vec<u8>) -> String {
    let npz = match Npz::read(Cursor::new(bytes), "broken.npz") {
        Ok(npz) => npz,
        Err(e) => return e.to_string(),
    };
    match EhmModel::from_npz(&npz, "broken".into()) {
        Ok(_) => panic!("a malformed model loaded"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn malformed_models_give_one_clear_error() {
    let mut parents: Vec<i32> = (-1..54).collect(); // a chain
    parents[20] = 30; // a parent after its child
    let mut weights = vec![0.0f32; 5143 * 5];
    weights.iter_mut().step_by(5).for_each(|w| *w = 0.5);
    let mut nan_template = vec![0.0f32; 5143 * 3];
    nan_template[77] = f32::NAN;
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (
            with_array("smplx_posedirs", None),
            "broken.npz: smplx_posedirs: missing",
        ),
        (
            with_array("format", Some(npy("<U14", &[], &[0; 56]))),
            "format is \"\"",
        ),
        (
            with_array(
                "flame_v_template",
                Some(npy("<f4", &[5143, 2], &f32_bytes(&vec![0.0; 5143 * 2]))),
            ),
            "flame_v_template: shape [5143, 2], expected [any, 3]",
        ),
        (
            with_array(
                "smplx_parents",
                Some(npy("<i4", &[55], &i32_bytes(&parents))),
            ),
            "smplx_parents: joint 20 has parent Some(30)",
        ),
        (
            with_array(
                "flame_weights",
                Some(npy("<f4", &[5143, 5], &f32_bytes(&weights))),
            ),
            "flame_weights: weights of vertex 0 sum to 0.5, not 1",
        ),
        (
            with_array(
                "flame_v_template",
                Some(npy("<f4", &[5143, 3], &f32_bytes(&nan_template))),
            ),
            "flame_v_template: element 77 is not finite",
        ),
        (
            with_array(
                "smplx_to_flame",
                Some(npy("<i4", &[5143], &i32_bytes(&vec![10_595; 5143]))),
            ),
            "smplx_to_flame: element 0 is 10595, outside 0..10595",
        ),
        (
            with_array("left_hand", Some(npy("<i4", &[778], &[0; 12]))),
            "left_hand: data is 12 bytes",
        ),
        (
            with_array(
                "uv_texel_face",
                Some(npy("<i4", &[32, 32], &i32_bytes(&vec![21_076; 32 * 32]))),
            ),
            "uv_texel_face: element 0 is 21076, outside -1..21076",
        ),
        (with_array("uv_texel_bary", None), "uv_texel_bary: missing"),
        (b"PK\x03\x04 not really".to_vec(), "not a .npz archive"),
    ];
    for (bytes, expected) in cases {
        let message = load_error(bytes);
        assert!(
            message.starts_with("broken.npz: ") && message.contains(expected),
            "{message:?} should name the file and say {expected:?}"
        );
    }
}

#[test]
fn cached_identity_gives_bit_identical_results() {
    let model = model();
    let npz = Npz::open(Path::new(PARITY)).expect("fixture");
    let mut p = params(&npz, 1);
    let (mut warm, mut fresh) = (PosedBody::default(), PosedBody::default());
    model.forward(&p, &mut warm, &mut EhmExtras::default());
    // Only the expression changes, as in playback: the identity part comes from the cache.
    p.expression.iter_mut().for_each(|e| *e = -*e);
    p.flame_expression[3] += 0.5;
    model.forward(&p, &mut warm, &mut EhmExtras::default());
    model
        .clone()
        .forward(&p, &mut fresh, &mut EhmExtras::default());
    assert_eq!(warm.vertices, fresh.vertices);
    assert_eq!(warm.skin, fresh.skin);
}

/// Avatar animation against the reference `Ubody_Gaussian.forward` on the synthetic EHM
/// (`tools/make_animation_fixture.py`): random template and UV Gaussians, posed by the "random"
/// and "extreme" parameter sets above.
#[test]
fn animation_matches_the_reference_ubody_gaussian() {
    use guava::avatar::{Avatar, AvatarKind, LocalGaussians, Rig, UvGaussians};
    use guava::gaussians::GaussianCloud;

    let model = model();
    let parity = Npz::open(Path::new(PARITY)).expect("EHM fixture");
    let npz = Npz::open(Path::new("tests/data/animation_parity.npz")).expect("animation fixture");
    let floats = |name: &str| {
        let rank = npz.shape(name).expect(name).len();
        npz.f32s(name, &vec![None; rank]).expect(name).0.to_vec()
    };
    let array = |name: &str, n| -> Vec<[f32; 4]> {
        floats(name)
            .chunks_exact(n)
            .map(|c| std::array::from_fn(|i| c.get(i).copied().unwrap_or(0.0)))
            .collect()
    };
    let triples = |name: &str| {
        array(name, 3)
            .into_iter()
            .map(|a| [a[0], a[1], a[2]])
            .collect()
    };
    let faces = model.triangles.len() as i64;
    let (uv_triangles, _) = npz
        .indices("uv_triangles", &[None], 0..faces)
        .expect("binding faces");
    let channels = npz.shape("template_features").expect("features")[1];
    let avatar = Avatar {
        kind: AvatarKind::Guava,
        body: model.name.clone(),
        body_vertices: model.body.template.len(),
        body_triangles: model.triangles.len(),
        channels,
        identity: Default::default(),
        ehm_identity: None,
        source: "animation_parity.npz".into(),
        source_view: None,
        displacements: Vec::new(),
        template: LocalGaussians {
            rotations: array("template_rotations", 4),
            scales: triples("template_scales"),
            opacities: floats("template_opacities"),
            features: floats("template_features"),
        },
        uv: UvGaussians {
            triangles: uv_triangles.iter().map(|&f| f as u32).collect(),
            barycentrics: triples("uv_barycentrics"),
            offsets: triples("uv_offsets"),
            local: LocalGaussians {
                rotations: array("uv_rotations", 4),
                scales: triples("uv_scales"),
                opacities: floats("uv_opacities"),
                features: floats("uv_features"),
            },
        },
        skinned: Default::default(),
        outside: 0,
    };
    let (cases, _) = npz.indices("cases", &[None], 0..3).expect("cases");
    let mut posed = PosedBody::default();
    let mut rig = Rig::default();
    let mut cloud = GaussianCloud::default();
    for (i, &k) in cases.iter().enumerate() {
        model.forward(
            &params(&parity, k as usize),
            &mut posed,
            &mut EhmExtras::default(),
        );
        rig.animate(&avatar, &posed, &model, &mut cloud)
            .expect("avatar fits the body");
        let slice = |name: &str| {
            let all = floats(name);
            let per = all.len() / cases.len();
            all[i * per..(i + 1) * per].to_vec()
        };
        let flat = |v: &[[f32; 3]]| v.iter().flatten().copied().collect::<Vec<f32>>();
        let worst = |a: &[f32], b: &[f32]| {
            assert_eq!(a.len(), b.len());
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f32::max)
        };
        let xyz = worst(&flat(&cloud.positions), &slice("out_xyz"));
        let scaling = worst(&flat(&cloud.scales), &slice("out_scaling"));
        let opacity = worst(&cloud.opacities, &slice("out_opacity"));
        // q and −q are one rotation; roma and we may pick either sign per Gaussian. A UV
        // Gaussian's frame comes from a cross product of its triangle's edges at corner 0, which
        // f32 resolves to ~1e-7 / sin θ (θ that corner's angle): on slivers (the synthetic
        // shape directions make some) the two sides' rounding parts further, so the bound is
        // 1e-5 scaled by 1/sin θ where that exceeds 1.
        let template = avatar.template.len();
        let mut rotation = 0.0f32;
        let mut over = 0;
        for (i, (q, r)) in cloud
            .rotations
            .iter()
            .zip(slice("out_rotation").chunks_exact(4))
            .enumerate()
        {
            let same = (0..4).map(|j| (q[j] - r[j]).abs()).fold(0.0, f32::max);
            let flipped = (0..4).map(|j| (q[j] + r[j]).abs()).fold(0.0, f32::max);
            let err = same.min(flipped);
            let condition = match i.checked_sub(template) {
                None => 1.0,
                Some(u) => {
                    let [a, b, c] = model.triangles[avatar.uv.triangles[u] as usize]
                        .map(|v| posed.vertices[v as usize]);
                    let (e0, e2) = (b - a, c - a);
                    (e0.length() * e2.length() / e0.cross(e2).length()).max(1.0)
                }
            };
            assert!(
                err <= 1e-5 * condition,
                "rotation {i}: {err:.2e} (1/sin θ {condition:.1})"
            );
            rotation = rotation.max(err);
            over += usize::from(err > 1e-5);
        }
        println!(
            "case {k}: {} Gaussians; max |Δ| position {xyz:.2e} m, rotation {rotation:.2e} \
             ({over} over 1e-5, each within 1e-5/sin θ), scale {scaling:.2e} m, opacity {opacity:.2e}",
            cloud.len()
        );
        // The 1e-5; both sides are f32 with different summation orders.
        assert!(xyz <= TOLERANCE_M, "positions {xyz:.2e}");
        assert!(scaling <= TOLERANCE_M, "scales {scaling:.2e}");
        assert_eq!(opacity, 0.0, "opacities pass through");
        assert_eq!(cloud.features.len(), cloud.len() * channels);
    }
}
