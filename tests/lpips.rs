//! LPIPS through a user's ONNX model (`guava eval --lpips`): the tiny fixture model made by
//! `tools/export_lpips_onnx.py --tiny 0` (LPIPS's own forward with a small random backbone)
//! gives PyTorch's distance through ONNX Runtime in Rust, zero for an image against itself, and
//! models that are not LPIPS are refused by name.

use std::path::{Path, PathBuf};

use guava::eval::lpips::{Lpips, LpipsError};
use guava::onnx::OnnxRuntime;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn rgb(name: &str) -> (Vec<f32>, usize, usize) {
    let image = image::open(data(name)).expect("fixture image").to_rgb8();
    let (w, h) = image.dimensions();
    let values = image.as_raw().iter().map(|v| *v as f32 / 255.0).collect();
    (values, w as usize, h as usize)
}

fn model() -> Lpips {
    let runtime = OnnxRuntime::load().expect("ONNX Runtime (bash tools/setup.sh installs it)");
    Lpips::load(runtime, &data("lpips/tiny_lpips.onnx")).expect("the fixture model")
}

/// Parity with PyTorch within 1e-4 relative (f32 on both sides; the images are the same 8-bit
/// pixels scaled to [-1, 1] the same way).
#[test]
fn the_fixture_model_gives_pytorchs_distance() {
    let expected: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(data("lpips/expected.json")).expect("expected.json"),
    )
    .expect("json");
    let want = expected["a_b"].as_f64().expect("a_b");
    let mut lpips = model();
    let ((a, w, h), (b, ..)) = (rgb("lpips/a.png"), rgb("lpips/b.png"));
    let got = lpips.distance(&a, &b, w, h).expect("runs");
    println!("LPIPS(a, b): Rust {got:.7}, PyTorch {want:.7}");
    assert!(want > 0.01, "the fixture images differ");
    assert!((got - want).abs() <= 1e-4 * want, "{got} vs {want}");
    assert_eq!(lpips.distance(&a, &a, w, h).expect("runs"), 0.0);
    // Swapping the images changes nothing (LPIPS is symmetric).
    let swapped = lpips.distance(&b, &a, w, h).expect("runs");
    assert!((swapped - got).abs() <= 1e-6, "{swapped} vs {got}");
}

#[test]
fn what_is_not_lpips_is_refused_by_name() {
    let runtime = OnnxRuntime::load().expect("ONNX Runtime");
    let refiner = Path::new(guava::refine::DEFAULT_REFINER);
    let err = Lpips::load(runtime, refiner).err().expect("refused");
    let text = err.to_string();
    assert!(
        text.contains("default_refiner.onnx") && text.contains("not an LPIPS model"),
        "{text}"
    );
    let mut lpips = model();
    let small = vec![0.5; 3 * 16 * 40];
    assert!(matches!(
        lpips.distance(&small, &small, 40, 16),
        Err(LpipsError::TooSmall {
            width: 40,
            height: 16
        })
    ));
}
