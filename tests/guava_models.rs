//! GUAVA mode's networks through ONNX Runtime: the reduced, randomly initialised models that
//! tools/export_guava_onnx.py builds from the authors' code, run here on the inputs the script
//! saved, against PyTorch's outputs on them; and the folder check's errors.

use std::path::{Path, PathBuf};

use glam::Vec3;
use guava::guava_mode::{GuavaModels, GuavaModelsError, models::FILES};
use guava::npz::Npz;
use guava::onnx::OnnxRuntime;
use guava::refine::{Refiner, RefinerKind};
use guava::render::SplatImage;

fn models_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/guava_onnx")
}

fn runtime() -> &'static OnnxRuntime {
    OnnxRuntime::load().expect("ONNX Runtime: run `bash tools/setup.sh` first")
}

/// max |got − want| / max |want|: the networks' outputs range over orders of magnitude (raw
/// colours, exp scales), so the error is relative to each tensor's own size.
fn relative_error(got: &[f32], want: &[f32]) -> f32 {
    assert_eq!(got.len(), want.len());
    let scale = want.iter().fold(0f32, |m, w| m.max(w.abs())).max(1e-12);
    let worst = got
        .iter()
        .zip(want)
        .fold(0f32, |m, (g, w)| m.max((g - w).abs()));
    worst / scale
}

#[test]
fn exported_networks_match_pytorch_within_1e4_relative() {
    let mut models = GuavaModels::load_dir(runtime(), &models_dir()).expect("models load");
    let d = models.dims;
    assert_eq!(
        (
            d.image,
            d.features,
            d.pixel_channels,
            d.vertex_channels,
            d.uv,
            d.colors,
            d.vertices
        ),
        (56, 32, 35, 8, 32, 8, 10_595),
        "the reduced export's sizes"
    );
    assert!(
        models.source.contains("random weights"),
        "{}",
        models.source
    );
    let npz = Npz::open(&models_dir().join("fixture.npz")).expect("fixture");
    let array = |name: &str| {
        npz.f32s(name, &[None; 4][..npz.shape(name).expect("fixture").len()])
            .expect("fixture")
            .0
            .to_vec()
    };
    let cam_dir = Vec3::from_slice(&array("vertex_decoder.in.cam_dir"));

    // Tolerance: PyTorch and ONNX Runtime sum convolutions and matmuls in different orders in
    // f32; the script measured ≤ 6e-6 (relative) with ONNX Runtime's Python build.
    let check = |what: &str, got: &[f32]| {
        let err = relative_error(got, &array(what));
        println!("{what}: {err:.2e}");
        assert!(err <= 1e-4, "{what}: relative error {err:.2e}");
    };
    let encoded = models
        .encode(&array("encoder.in.image"))
        .expect("encoder runs");
    check("encoder.out.pixel_features", &encoded.pixel_features);
    check("encoder.out.vertex_features", &encoded.vertex_features);
    check("encoder.out.vertex_global", &encoded.vertex_global);
    check("encoder.out.uv_style", &encoded.uv_style);

    // The decoders take the fixture's own inputs (random, not the encoder's outputs above).
    let mut fixture_encoded = encoded;
    fixture_encoded.vertex_global = array("vertex_decoder.in.vertex_global");
    fixture_encoded.uv_style = array("uv_decoder.in.uv_style");
    let v = models
        .decode_vertices(
            array("vertex_decoder.in.sampled"),
            &fixture_encoded,
            cam_dir,
        )
        .expect("vertex decoder runs");
    check("vertex_decoder.out.colors", &v.colors);
    check("vertex_decoder.out.opacities", &v.opacities);
    check("vertex_decoder.out.scales", &v.scales);
    check("vertex_decoder.out.rotations", &v.rotations);
    let uv = models
        .decode_uv(
            array("uv_decoder.in.uv_features"),
            &fixture_encoded,
            cam_dir,
        )
        .expect("UV decoder runs");
    check("uv_decoder.out.colors", &uv.colors);
    check("uv_decoder.out.opacities", &uv.opacities);
    check("uv_decoder.out.scales", &uv.scales);
    check("uv_decoder.out.rotations", &uv.rotations);
    check("uv_decoder.out.local_pos", &uv.local_pos);

    // GUAVA's refiner, through the frame path's own loader, at its own side (no resampling).
    let mut refiner = Refiner::load(runtime(), &models.refiner_path()).expect("refiner loads");
    assert_eq!(
        refiner.kind,
        RefinerKind::Guava {
            channels: d.colors,
            side: d.features
        }
    );
    let side = d.features as u32;
    let mut splat = SplatImage::new(side, side, d.colors);
    splat.features = array("refiner.in.splat");
    splat.alpha = vec![1.0; splat.alpha.len()];
    let refined = refiner.refine(&splat).expect("refiner runs");
    check("refiner.out.rgb", &refined.features);
}

#[test]
fn guava_refiner_refuses_another_avatars_channels_and_letterboxes_other_frames() {
    let mut refiner = Refiner::load(runtime(), &models_dir().join(FILES[3].1)).expect("loads");
    let RefinerKind::Guava { channels, .. } = refiner.kind else {
        panic!("GUAVA's refiner, by its metadata");
    };
    // A default-mode avatar's frame (RGB and confidence) is refused with the file named.
    let message = refiner
        .refine(&SplatImage::new(40, 24, 4))
        .expect_err("4 channels refused")
        .to_string();
    assert!(
        message.contains("guava_refiner.onnx") && message.contains(&format!("{channels} channels")),
        "{message}"
    );
    // A wide frame comes back at its own size, finite, with its alpha.
    let mut frame = SplatImage::new(48, 20, channels);
    for (i, v) in frame.features.iter_mut().enumerate() {
        *v = ((i * 7919) % 97) as f32 / 97.0;
    }
    frame.alpha.iter_mut().for_each(|a| *a = 0.5);
    let refined = refiner.refine(&frame).expect("letterboxed");
    assert_eq!(
        (refined.width, refined.height, refined.channels),
        (48, 20, 3)
    );
    assert_eq!(refined.features.len(), 3 * 48 * 20);
    assert!(refined.features.iter().all(|v| v.is_finite()));
    assert_eq!(refined.alpha, frame.alpha);
}

fn problems(dir: &Path) -> Vec<String> {
    match GuavaModels::load_dir(runtime(), dir) {
        Err(GuavaModelsError::Invalid { problems, .. }) => problems,
        Err(e) => panic!("expected a folder error, got {e}"),
        Ok(_) => panic!("{} must not load", dir.display()),
    }
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("guava-models-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

#[test]
fn a_folder_missing_models_names_every_missing_file() {
    let dir = scratch("missing");
    std::fs::copy(models_dir().join(FILES[1].1), dir.join(FILES[1].1)).expect("copy");
    let found = problems(&dir);
    assert_eq!(
        found,
        [
            format!("{}: missing", FILES[0].1),
            format!("{}: missing", FILES[2].1),
            format!("{}: missing", FILES[3].1)
        ],
    );
    let message = GuavaModels::load_dir(runtime(), &dir)
        .err()
        .expect("fixture")
        .to_string();
    assert!(message.contains(&dir.display().to_string()), "{message}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn swapped_or_broken_models_are_named() {
    let dir = scratch("swapped");
    // The encoder saved under the UV decoder's name, the vertex decoder truncated to half.
    std::fs::copy(models_dir().join(FILES[0].1), dir.join(FILES[0].1)).expect("copy");
    std::fs::copy(models_dir().join(FILES[0].1), dir.join(FILES[2].1)).expect("copy");
    std::fs::copy(models_dir().join(FILES[3].1), dir.join(FILES[3].1)).expect("copy");
    let bytes = std::fs::read(models_dir().join(FILES[1].1)).expect("read");
    std::fs::write(dir.join(FILES[1].1), &bytes[..bytes.len() / 2]).expect("write");
    let found = problems(&dir);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].starts_with(FILES[1].1), "{found:?}");
    std::fs::write(dir.join(FILES[1].1), &bytes).expect("write");
    let found = problems(&dir);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(
        found[0].starts_with(FILES[2].1) && found[0].contains("role \"encoder\""),
        "{found:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
