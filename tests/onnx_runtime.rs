//! ONNX Runtime as a real component: load the library tools/setup.sh installs, run a small model
//! made by tools/make_onnx_fixture.py, and compare with the outputs onnx's reference evaluator gave.

use guava::onnx::{OnnxRuntime, TensorF32};
use std::path::Path;

fn fixture() -> (Vec<usize>, Vec<f32>, Vec<usize>, Vec<f32>) {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny_mlp.json"),
    )
    .expect("tests/data/tiny_mlp.json");
    // The fixture is flat JSON with four numeric arrays; pull each out by key.
    let array = |key: &str| -> Vec<f64> {
        let start = text.find(&format!("\"{key}\"")).expect(key);
        let open = start + text[start..].find('[').expect("[");
        let close = open + text[open..].find(']').expect("]");
        text[open + 1..close]
            .split(',')
            .map(|v| v.trim().parse::<f64>().expect("number"))
            .collect()
    };
    let shape = |key| array(key).into_iter().map(|v| v as usize).collect();
    let values = |key| array(key).into_iter().map(|v| v as f32).collect();
    (
        shape("input_shape"),
        values("input"),
        shape("output_shape"),
        values("output"),
    )
}

#[test]
fn runs_a_model_and_matches_the_reference_evaluator() {
    let runtime = OnnxRuntime::load().expect("ONNX Runtime: run `bash tools/setup.sh` first");
    println!(
        "ONNX Runtime {} from {}",
        runtime.version,
        runtime.library.display()
    );
    assert_eq!(runtime.version, guava::onnx::PINNED_VERSION);
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny_mlp.onnx");
    let mut session = runtime.session(&model).expect("model loads");
    // Says what runs it: the CPU in the default build; with a GPU provider's cargo feature,
    // the provider by name, registered or with why it did not (the shipped library is the
    // CPU build, so here it does not).
    println!("engine: {}", session.engine);
    match guava::onnx::requested_providers().starts_with("none") {
        true => assert_eq!(session.engine, "ONNX Runtime (CPU)"),
        false => {
            for name in guava::onnx::requested_providers().split(", ") {
                assert!(session.engine.contains(name), "{}", session.engine);
            }
        }
    }
    assert_eq!(session.input_names(), ["x"]);
    assert_eq!(session.output_names(), ["y"]);
    let (in_shape, input, out_shape, expected) = fixture();
    let outputs = session
        .run(vec![(
            "x",
            TensorF32 {
                shape: in_shape,
                data: input,
            },
        )])
        .expect("model runs");
    assert_eq!(outputs[0].shape, out_shape);
    for (got, want) in outputs[0].data.iter().zip(&expected) {
        // Softplus and pooling in f32: agreement to a few ulps.
        assert!(
            (got - want).abs() <= 1e-5 * want.abs().max(1.0),
            "{got} vs {want}"
        );
    }
}

#[test]
fn bad_models_give_errors_naming_the_file() {
    let runtime = OnnxRuntime::load().expect("ONNX Runtime: run `bash tools/setup.sh` first");
    let missing = Path::new("/nonexistent/model.onnx");
    let err = runtime
        .session(missing)
        .err()
        .expect("missing file")
        .to_string();
    assert!(
        err.contains("/nonexistent/model.onnx") && err.contains("no such file"),
        "{err}"
    );

    let garbage = std::env::temp_dir().join(format!("guava-garbage-{}.onnx", std::process::id()));
    std::fs::write(&garbage, b"this is not a protobuf").expect("write");
    let err = runtime
        .session(&garbage)
        .err()
        .expect("garbage model")
        .to_string();
    assert!(err.contains(&garbage.display().to_string()), "{err}");
    std::fs::remove_file(&garbage).ok();

    // Wrong input shape: an error from the run, not a crash.
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tiny_mlp.onnx");
    let mut session = runtime.session(&model).expect("model loads");
    let err = session
        .run(vec![(
            "x",
            TensorF32 {
                shape: vec![2, 5],
                data: vec![0.0; 10],
            },
        )])
        .err()
        .expect("wrong shape");
    assert!(err.to_string().contains("tiny_mlp.onnx"), "{err}");
}
