//! GUAVA mode end to end: the geometry between the networks against the reference
//! (tools/make_guava_sampling_fixture.py), and the whole reconstruction with the reduced,
//! randomly initialised networks (tests/data/guava_onnx) on the synthetic EHM.

use std::path::Path;

use glam::{Mat4, Vec3};
use guava::avatar::{AvatarKind, Rig};
use guava::body::{BodyPose, EhmModel, Posable, PosedBody};
use guava::camera::Camera;
use guava::gaussians::GaussianCloud;
use guava::guava_mode::reconstruct::{PRUNE_OPACITY, Projection};
use guava::guava_mode::{GuavaModels, reconstruct_guava, uv_map};
use guava::npz::Npz;
use guava::onnx::OnnxRuntime;
use guava::photo::SourceImage;
use guava::pipeline::{KeypointModels, Mode, Photo, Pipeline, Tracked};
use guava::reconstruct::{ReconstructError, UvMap};
use guava::tracking::SourceView;

fn model() -> EhmModel {
    EhmModel::load(Path::new("tests/data/ehm_synthetic.npz")).expect("synthetic EHM loads")
}

fn floats(npz: &Npz, name: &str) -> Vec<f32> {
    let rank = npz.shape(name).expect(name).len();
    npz.f32s(name, &vec![None; rank]).expect(name).0.to_vec()
}

fn max_abs_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
fn sampling_and_inverse_texture_mapping_match_the_reference() {
    let model = model();
    let npz = Npz::open(Path::new("tests/data/guava_sampling_parity.npz")).expect("fixture");
    let vertices: Vec<Vec3> = floats(&npz, "vertices")
        .chunks_exact(3)
        .map(Vec3::from_slice)
        .collect();
    let w2c = Mat4::from_cols_slice(&floats(&npz, "w2c")).transpose();
    let projection = Projection {
        w2c,
        invtanfov: floats(&npz, "invtanfov")[0],
    };
    let side = npz.shape("vertex_maps").expect("fixture")[1];
    let sampled = projection.sample_vertices(
        &vertices,
        &floats(&npz, "vertex_maps"),
        npz.shape("vertex_maps").expect("fixture")[0],
        side,
    );
    let vertex_err = max_abs_diff(&sampled, &floats(&npz, "out_sampled"));

    // The reference's own texel map and visible faces, so both sides sample the same points.
    let size = npz.shape("uvmap_f_idx").expect("fixture")[0];
    let faces = model.triangles.len() as i64;
    let (f_idx, _) = npz
        .indices("uvmap_f_idx", &[Some(size), Some(size)], -1..faces)
        .expect("fixture");
    let bary: Vec<[f32; 3]> = floats(&npz, "uvmap_f_bary")
        .chunks_exact(3)
        .map(|b| [b[0], b[1], b[2]])
        .collect();
    let uv = UvMap {
        size: size as u32,
        triangle: f_idx.iter().map(|&f| f as i32).collect(),
        bary,
        texels: (0..f_idx.len() as u32)
            .filter(|&i| f_idx[i as usize] >= 0)
            .collect(),
        mirror: vec![-1; f_idx.len()],
    };
    let mut visible = vec![false; model.triangles.len()];
    for &f in npz
        .indices("visible_faces", &[None], 0..faces)
        .expect("fixture")
        .0
    {
        visible[f as usize] = true;
    }
    let channels = npz.shape("pixel_maps").expect("fixture")[0];
    let (mapped, observed) = projection.texture_map(
        &uv,
        &vertices,
        &model.triangles,
        &visible,
        &floats(&npz, "pixel_maps"),
        channels,
        side,
    );
    let reference = floats(&npz, "out_uv_features");
    let texel_err = max_abs_diff(&mapped, &reference);
    let plane = size * size;
    let reference_observed = (0..plane)
        .filter(|&i| (0..channels).any(|c| reference[c * plane + i] != 0.0))
        .count();
    println!(
        "vertices: max |Δ| {vertex_err:.2e}; texels: max |Δ| {texel_err:.2e}, {observed} \
         sampled (reference {reference_observed}) of {}",
        uv.len()
    );
    // f32 on both sides: the pixel coordinate (±32 at 24·x/z) carries ~4e-6 of rounding, times
    // the maps' gradients (unit normal values, up to ~4 per pixel).
    assert!(vertex_err <= 1e-4, "vertex sampling {vertex_err:.2e}");
    assert!(texel_err <= 1e-4, "inverse texture mapping {texel_err:.2e}");
    assert_eq!(observed, reference_observed);
}

/// The reduced models, built for the synthetic EHM's 10,595 vertices and a 32² UV map.
fn models() -> GuavaModels {
    let runtime = OnnxRuntime::load().expect("ONNX Runtime: run `bash tools/setup.sh` first");
    GuavaModels::load_dir(runtime, Path::new("tests/data/guava_onnx")).expect("models load")
}

/// A source view GUAVA's tracker would give: the posed body 22 m in front of the camera.
fn view(model: &EhmModel) -> SourceView {
    let w2c = Mat4::from_cols_array_2d(&[
        [1.0, 0.0, 0.0, 0.0],
        [0.0, -1.0, 0.0, 0.0],
        [0.0, 0.0, -1.0, 0.0],
        [0.0, 0.2, 22.0, 1.0],
    ]);
    let mut pose = BodyPose::rest(model);
    pose.set_rotation(model, "left_elbow", Vec3::new(0.0, 0.0, 0.8))
        .expect("joint");
    SourceView {
        pose,
        camera: Camera::guava(w2c, 512, 24.0),
        crop: None,
    }
}

/// A test card: a smooth colour ramp over a dark border, opaque where a person would stand.
fn card(side: u32) -> image::RgbaImage {
    image::RgbaImage::from_fn(side * 4, side * 4, |x, y| {
        let inside = (x as i32 - 2 * side as i32).abs() < side as i32;
        image::Rgba([
            (x % 256) as u8,
            (y % 256) as u8,
            128,
            if inside { 255 } else { 0 },
        ])
    })
}

fn photo(side: u32) -> SourceImage {
    SourceImage::from_rgba_at(&card(side), None, true, "card.png", side).expect("image")
}

#[test]
fn reconstruction_with_reduced_networks_animates_and_refuses_mismatches() {
    let model = model();
    let mut models = models();
    let d = models.dims;
    let uv = uv_map(&model, d.uv as u32);
    // The synthetic EHM carries the reference's OpenCV-filled texel map at this size.
    let reference = model.reference_texels.as_ref().expect("reference texels");
    assert_eq!(reference.size as usize, d.uv);
    assert_eq!(uv.triangle, reference.triangle);
    assert_eq!(
        uv.len(),
        reference.triangle.iter().filter(|&&t| t >= 0).count()
    );
    let view = view(&model);
    let mut stages = Vec::new();
    let (avatar, report) = reconstruct_guava(
        &mut models,
        &model,
        &uv,
        &view,
        &photo(d.image as u32),
        "card.png",
        &mut |s| {
            stages.push(s);
            true
        },
    )
    .expect("reconstructs");
    println!("{report:?}");
    assert_eq!(avatar.kind, AvatarKind::Guava);
    assert_eq!(avatar.template.len(), model.body.template.len());
    assert_eq!(avatar.uv.local.len() + report.pruned, uv.len());
    assert!(avatar.uv.local.opacities.iter().all(|&o| o > PRUNE_OPACITY));
    assert!(report.visible_faces > 0 && report.visible_faces < model.triangles.len());
    assert!(report.observed > 0 && report.observed < uv.len());
    // Every vertex is in front of this camera; the body stands inside the view.
    let mut posed = PosedBody::default();
    model.pose(&view.pose, &mut posed).expect("pose");
    let projected: Vec<_> = posed
        .vertices
        .iter()
        .map(|&v| view.camera.project(v))
        .collect();
    assert!(projected.iter().all(|p| p.z > 0.0));
    let side = view.camera.width as f32;
    let inside = projected
        .iter()
        .filter(|p| (0.0..=side).contains(&p.x) && (0.0..=side).contains(&p.y))
        .count();
    assert!(inside > projected.len() / 2, "{inside} inside the view");
    assert_eq!(
        stages.len(),
        report.timings.len(),
        "every stage reported and timed"
    );
    let rgb_in_unit = |f: &[f32]| {
        f.chunks_exact(avatar.channels)
            .all(|g| g[..3].iter().all(|v| (0.0..=1.0).contains(v)))
    };
    assert!(rgb_in_unit(&avatar.template.features) && rgb_in_unit(&avatar.uv.local.features));

    // It animates on its body, and the same pose twice gives the same cloud.
    let mut posed = PosedBody::default();
    model.pose(&view.pose, &mut posed).expect("pose");
    let (mut rig, mut cloud) = (Rig::default(), GaussianCloud::default());
    rig.animate(&avatar, &posed, &model, &mut cloud)
        .expect("animates");
    assert_eq!(cloud.len(), avatar.len());
    assert!(cloud.positions.iter().flatten().all(|v| v.is_finite()));

    // `guava eval`'s metrics run on it as on a default-mode avatar, from the view it keeps (with
    // random networks this checks the code path, not fidelity).
    let (m, rendered) = guava::eval::evaluate(
        &mut crate::common::renderer(),
        &avatar,
        &model,
        None,
        &photo(view.camera.width),
    )
    .expect("evaluates");
    println!("{m}");
    assert_eq!(rendered.channels, avatar.channels);
    assert!((0.0..=1.0).contains(&m.iou) && m.iou > 0.0, "{m}");
    assert!(
        m.psnr.is_finite() && m.ssim.is_finite() && m.l1.is_finite(),
        "{m}"
    );

    // A photo at the wrong size is refused, naming both sizes; cancelling stops it.
    let err = reconstruct_guava(
        &mut models,
        &model,
        &uv,
        &view,
        &photo(64),
        "x",
        &mut |_| true,
    )
    .expect_err("wrong size");
    let sizes = ["64²".to_string(), format!("{}²", d.image)];
    assert!(
        matches!(&err, ReconstructError::Models(m) if sizes.iter().all(|s| m.contains(s))),
        "{err}"
    );
    let err = reconstruct_guava(
        &mut models,
        &model,
        &uv,
        &view,
        &photo(d.image as u32),
        "x",
        &mut |_| false,
    )
    .expect_err("cancelled");
    assert!(matches!(err, ReconstructError::Cancelled(_)));
}

#[test]
fn extreme_views_and_nan_poses_give_finite_avatars_or_clear_errors() {
    let model = model();
    let mut models = models();
    let d = models.dims;
    let uv = uv_map(&model, d.uv as u32);
    let photo = photo(d.image as u32);
    let finite = |a: &guava::avatar::Avatar| {
        let t = &a.template;
        let u = &a.uv.local;
        t.features.iter().chain(&u.features).all(|v| v.is_finite())
            && t.scales
                .iter()
                .chain(&u.scales)
                .flatten()
                .all(|v| v.is_finite())
            && a.uv.offsets.iter().flatten().all(|v| v.is_finite())
    };
    let run = |models: &mut GuavaModels, view: &SourceView| {
        reconstruct_guava(models, &model, &uv, view, &photo, "x", &mut |_| true)
    };

    // NaN and infinite joint angles: EHM treats them as zero and counts them.
    let mut nan_view = view(&model);
    nan_view.pose.rotations[3] = Vec3::new(f32::NAN, f32::INFINITY, 0.0);
    let (avatar, _) = run(&mut models, &nan_view).expect("NaN pose still reconstructs");
    assert!(finite(&avatar));

    // The camera inside the body (at the pelvis, z = 0 on some vertices): projection divides by
    // z + 1e-7 and sampling clamps or zero-pads, so features stay finite.
    let mut inside = view(&model);
    inside.camera.view_from_world = Mat4::from_cols_array_2d(&[
        [1.0, 0.0, 0.0, 0.0],
        [0.0, -1.0, 0.0, 0.0],
        [0.0, 0.0, -1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]);
    match run(&mut models, &inside) {
        Ok((avatar, _)) => assert!(finite(&avatar)),
        Err(e) => assert!(matches!(e, ReconstructError::NothingVisible), "{e}"),
    }

    // Looking away from the body: nothing visible is a clear error, not an empty avatar.
    let mut away = view(&model);
    away.camera.view_from_world = Mat4::from_translation(Vec3::new(0.0, 0.0, -22.0));
    let err = run(&mut models, &away).expect_err("nothing visible");
    assert!(matches!(err, ReconstructError::NothingVisible), "{err}");
}

/// The tracker's skeleton (joint offsets, head and hand scale) belongs to the person: the file
/// path builds the body with the tracking's, the avatar keeps it through its file and poses with
/// it, and a broken one is refused by name.
#[test]
fn tracked_ehm_identity_is_reconstructed_with_and_kept() {
    use guava::avatar::Avatar;
    use guava::tracking::EhmIdentityRecord;

    let mut model = model();
    let mut models = models();
    let d = models.dims;
    let dir = std::env::temp_dir().join(format!("guava-ehm-identity-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (photo_path, tracking_path) = (dir.join("card.png"), dir.join("card.json"));
    card(d.image as u32).save(&photo_path).expect("photo");
    let mut identity = EhmIdentityRecord::of(&Default::default());
    identity.head_scale = [1.4, 1.3, 1.2];
    identity.joints_offset[16] = [0.0, 0.05, 0.0];
    let mut pipeline = Pipeline::default();
    let mut run = |ehm: Option<EhmIdentityRecord>, photo: &Path, tracking: &Path| {
        crate::common::ehm_rest_tracking(ehm)
            .save(tracking)
            .expect("tracking");
        let mode = Mode::Guava {
            body: &model,
            networks: &mut models,
        };
        let tracked = Tracked::File(tracking.to_path_buf());
        pipeline
            .reconstruct(mode, Photo::File(photo), tracked, &mut |_| true)
            .expect("reconstructs")
            .avatar
    };
    let tracked = run(Some(identity.clone()), &photo_path, &tracking_path);
    let neutral = run(None, &photo_path, &tracking_path);
    assert_eq!(tracked.ehm_identity.as_ref(), Some(&identity));
    assert_eq!(
        neutral.ehm_identity,
        Some(EhmIdentityRecord::of(&Default::default()))
    );
    // The scaled head sits elsewhere in the photo, so its vertices sample other features.
    assert_ne!(tracked.template.features, neutral.template.features);

    // A photo without alpha is masked by the pose model's segmentation, at the encoder's side,
    // which the pose model's 256² input does not divide (this panicked before).
    let opaque = dir.join("opaque.png");
    image::DynamicImage::ImageRgba8(card(d.image as u32))
        .to_rgb8()
        .save(&opaque)
        .expect("opaque photo");
    let masked = run(None, &opaque, &dir.join("opaque.json"));
    assert_eq!(masked.template.len(), model.body.template.len());

    // Posed with its own identity, the avatar's head is the tracked size.
    let head_height = |model: &EhmModel| {
        let mut posed = PosedBody::default();
        model
            .pose(&BodyPose::rest(model), &mut posed)
            .expect("pose");
        let ys = model
            .head_vertices
            .iter()
            .map(|&v| posed.vertices[v as usize].y);
        ys.clone().fold(f32::MIN, f32::max) - ys.fold(f32::MAX, f32::min)
    };
    let neutral_height = head_height(&model);
    tracked.apply_ehm_identity(&mut model);
    let ratio = head_height(&model) / neutral_height;
    assert!((ratio - 1.3).abs() < 0.05, "head height ×{ratio}");

    // Through the file, and refused when broken.
    let file = dir.join("card.guava");
    tracked.save(&file).expect("save");
    assert_eq!(Avatar::load(&file).expect("load"), tracked);
    let broken = crate::common::edit_avatar_header(
        &std::fs::read(&file).expect("read"),
        "\"head_scale\":[1.4,",
        "\"head_scale\":[0.0,",
    );
    let err = Avatar::from_bytes(&broken, "bad.guava").expect_err("zero scale");
    assert!(err.to_string().contains("ehm_identity.head_scale"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A photo without a tracking file is fitted in GUAVA mode: the keypoint models' points on the
/// demo portrait fitted on the synthetic EHM (its random skinning makes the pose meaningless;
/// `ehm_fit` checks the fit's answers on a body that means something), the fit reported with the
/// reconstruction. Without the keypoint models, or with nobody in the photo, the error says so
/// and names the photo.
#[test]
fn guava_mode_fits_a_photo_without_tracking() {
    let model = model();
    let mut models = models();
    let d = models.dims;
    let photo = Path::new("assets/demo_portrait.png");
    let mut run = |photo: &Path, pipeline: &mut Pipeline| {
        let mode = Mode::Guava {
            body: &model,
            networks: &mut models,
        };
        pipeline
            .reconstruct(mode, Photo::File(photo), Tracked::Fit, &mut |_| true)
            .map(|o| (o.avatar, o.report, o.view))
    };
    let missing = KeypointModels::new(Some("no/such/folder".into()), None);
    let err = run(photo, &mut Pipeline::new(missing)).expect_err("no keypoint models");
    let text = err.to_string();
    assert!(
        text.contains("demo_portrait.png") && text.contains("keypoint models"),
        "{text}"
    );

    let mut pipeline = Pipeline::default();
    let (avatar, report, view) = run(photo, &mut pipeline).expect("fits and reconstructs");
    let fit = report.fit.expect("the fit is reported");
    println!(
        "synthetic EHM fitted to {} keypoints, {:.1} px RMS",
        fit.keypoints_used, fit.rms_px
    );
    assert!(fit.keypoints_used >= 4);
    assert_eq!(avatar.template.len(), model.body.template.len());
    assert_eq!(view.pose.rotations.len(), 55);

    let dir = std::env::temp_dir().join(format!("guava-ehm-fit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let empty = dir.join("empty.png");
    image::RgbImage::from_pixel(d.image as u32, d.image as u32, image::Rgb([128, 128, 128]))
        .save(&empty)
        .expect("photo");
    let err = run(&empty, &mut pipeline).expect_err("nobody to fit");
    let text = err.to_string();
    assert!(
        text.contains("empty.png") && text.contains("no person"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
