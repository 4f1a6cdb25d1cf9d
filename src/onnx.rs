//! ONNX Runtime through the `ort` crate, loaded at run time from the `libonnxruntime` that
//! `tools/setup.sh` installs under `target/onnxruntime/` (pinned PyPI wheel; nothing downloads at
//! build time). Every learned stage (GUAVA's encoders, decoders and refiner) runs through here.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The version `tools/setup.sh` installs; ort rc.15 needs 1.31 or newer.
pub const PINNED_VERSION: &str = "1.32.0";
const INSTALL_HINT: &str = "run `bash tools/setup.sh` (it installs the pinned library into \
    target/onnxruntime/) or set ORT_DYLIB_PATH to a libonnxruntime 1.31 or newer";

#[derive(Debug, Error)]
pub enum OnnxError {
    #[error("ONNX Runtime library not found (looked in {searched}); {INSTALL_HINT}")]
    NotFound { searched: String },
    #[error("ONNX Runtime library {path} could not be loaded: {reason}; {INSTALL_HINT}")]
    Load { path: PathBuf, reason: String },
    #[error("ONNX model {path}: {reason}")]
    Model { path: PathBuf, reason: String },
    #[error("ONNX model {path}: running it failed: {reason}")]
    Run { path: PathBuf, reason: String },
}

/// A loaded ONNX Runtime: the environment every session is built from.
pub struct OnnxRuntime {
    env: ort::environment::Environment,
    pub library: PathBuf,
    pub version: String,
}

impl std::fmt::Debug for OnnxRuntime {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OnnxRuntime")
            .field("library", &self.library)
            .field("version", &self.version)
            .finish()
    }
}

/// Where the library is looked for, in order: `$ORT_DYLIB_PATH`, then `onnxruntime/` in every
/// folder above the running executable (so `target/release/guava` finds `target/onnxruntime/`).
pub fn candidate_paths() -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Some(p) = std::env::var_os("ORT_DYLIB_PATH") {
        out.push(PathBuf::from(p));
    }
    if let Ok(exe) = std::env::current_exe() {
        for dir in exe.ancestors().skip(1) {
            out.push(dir.join("onnxruntime").join(library_file_name()));
        }
    }
    out.push(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("target/onnxruntime")
            .join(library_file_name()),
    );
    out
}

fn library_file_name() -> &'static str {
    if cfg!(target_os = "windows") {
        "onnxruntime.dll"
    } else if cfg!(target_os = "macos") {
        "libonnxruntime.dylib"
    } else {
        "libonnxruntime.so"
    }
}

impl OnnxRuntime {
    /// The process's runtime: found and loaded on first use, then shared (ONNX Runtime allows one
    /// environment per process). A failed load is retried on the next call.
    pub fn load() -> Result<&'static Self, OnnxError> {
        static SHARED: std::sync::Mutex<Option<&'static OnnxRuntime>> = std::sync::Mutex::new(None);
        let mut shared = SHARED.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(runtime) = *shared {
            return Ok(runtime);
        }
        let runtime: &'static Self = Box::leak(Box::new(Self::find_and_load()?));
        *shared = Some(runtime);
        Ok(runtime)
    }

    fn find_and_load() -> Result<Self, OnnxError> {
        let candidates = candidate_paths();
        let path = candidates
            .iter()
            .find(|p| p.is_file())
            .cloned()
            .ok_or_else(|| OnnxError::NotFound {
                searched: candidates
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        Self::load_from(&path)
    }

    pub fn load_from(path: &Path) -> Result<Self, OnnxError> {
        let load_err = |reason: String| OnnxError::Load {
            path: path.to_path_buf(),
            reason,
        };
        // ort panics (instead of returning an error) on some dlopen failures: contain that here.
        let env = catch_unwind(AssertUnwindSafe(|| -> Result<_, String> {
            let builder = ort::init_from(path).map_err(|e| e.to_string())?;
            // One pool of threads for every session, idle threads sleeping: with a pool per
            // session, spinning after each run (ONNX Runtime's default), the seven keypoint
            // models of a video frame took each other's cores, and the pose model ran at half
            // its speed; spinning also took the CPU a viewer frame (lavapipe) needs.
            let threads = ort::environment::GlobalThreadPoolOptions::default()
                .with_spin_control(false)
                .map_err(|e| e.to_string())?;
            builder
                .with_name("guava")
                .with_global_thread_pool(threads)
                .build()
                .map_err(|e| e.to_string())
        }))
        .map_err(|panic| load_err(panic_message(&panic)))?
        .map_err(load_err)?;
        let version = version_from_file_name(path).unwrap_or_else(|| "unknown version".into());
        Ok(Self {
            env,
            library: path.to_path_buf(),
            version,
        })
    }

    /// A session on one CPU thread pool; `path` names the model in every error.
    pub fn session(&self, path: &Path) -> Result<Session, OnnxError> {
        let model_err = |e: ort::Error| OnnxError::Model {
            path: path.to_path_buf(),
            reason: e.to_string(),
        };
        if !path.is_file() {
            return Err(OnnxError::Model {
                path: path.to_path_buf(),
                reason: "no such file".into(),
            });
        }
        // Each requested provider on its own, so that the session can say which registered and
        // why one did not (asked together, ONNX Runtime skips failures silently).
        let mut builder = ort::session::Session::builder(&self.env).map_err(model_err)?;
        let (mut registered, mut failed) = (Vec::new(), Vec::new());
        for (name, provider) in execution_providers() {
            builder = match builder.with_execution_providers([provider.error_on_failure()]) {
                Ok(b) => {
                    registered.push(name);
                    b
                }
                Err(e) => {
                    failed.push(format!("{name} did not register: {e}"));
                    e.recover()
                }
            };
        }
        let inner = builder.commit_from_file(path).map_err(model_err)?;
        let mut engine = match registered.is_empty() {
            true => "ONNX Runtime (CPU)".to_string(),
            false => format!(
                "ONNX Runtime ({}; operators it lacks on the CPU)",
                registered.join(", ")
            ),
        };
        if !failed.is_empty() {
            engine += &format!(" — {}", failed.join("; "));
        }
        Ok(Session {
            inner,
            path: path.to_path_buf(),
            engine,
        })
    }
}

/// The GPU execution providers this build asks for, in order (cargo features `cuda`, `directml`,
/// `coreml`; none by default): each that the loaded library cannot register is skipped and the
/// session runs on the CPU (checked with `cuda` against the CPU build: the same images).
fn execution_providers() -> Vec<(&'static str, ort::ep::ExecutionProviderDispatch)> {
    vec![
        #[cfg(feature = "cuda")]
        ("CUDA", ort::ep::CUDA::default().build()),
        #[cfg(feature = "directml")]
        ("DirectML", ort::ep::DirectML::default().build()),
        #[cfg(feature = "coreml")]
        ("CoreML", ort::ep::CoreML::default().build()),
    ]
}

/// The GPU execution providers this build asks for, by name.
pub fn requested_providers() -> String {
    let built = [
        (cfg!(feature = "cuda"), "CUDA"),
        (cfg!(feature = "directml"), "DirectML"),
        (cfg!(feature = "coreml"), "CoreML"),
    ];
    let names: Vec<&str> = built
        .iter()
        .filter(|(on, _)| *on)
        .map(|(_, n)| *n)
        .collect();
    match names.is_empty() {
        true => "none (the CPU only; cargo features cuda, directml, coreml)".into(),
        false => names.join(", "),
    }
}

/// One loaded model. Inputs and outputs are plain f32 tensors: (shape, row-major data).
pub struct Session {
    inner: ort::session::Session,
    pub path: PathBuf,
    /// What runs it: "ONNX Runtime (CPU)", or the GPU providers that registered, and any that
    /// were asked for and did not, with ONNX Runtime's reason.
    pub engine: String,
}

pub struct TensorF32 {
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
}

impl Session {
    pub fn input_names(&self) -> Vec<String> {
        self.inner
            .inputs()
            .iter()
            .map(|i| i.name().to_string())
            .collect()
    }

    pub fn output_names(&self) -> Vec<String> {
        self.inner
            .outputs()
            .iter()
            .map(|o| o.name().to_string())
            .collect()
    }

    /// Each input's name and shape (−1 where a dimension is not fixed).
    pub fn input_shapes(&self) -> Vec<(String, Vec<i64>)> {
        shapes(self.inner.inputs())
    }

    /// Each output's name and shape (−1 where a dimension is not fixed).
    pub fn output_shapes(&self) -> Vec<(String, Vec<i64>)> {
        shapes(self.inner.outputs())
    }

    /// A value of the model's custom metadata (`metadata_props`), if it has that key.
    pub fn metadata(&self, key: &str) -> Option<String> {
        self.inner.metadata().ok()?.custom(key)
    }

    /// Runs the model on named inputs and returns every output in the model's order.
    pub fn run(&mut self, inputs: Vec<(&str, TensorF32)>) -> Result<Vec<TensorF32>, OnnxError> {
        let run_err = |e: ort::Error| OnnxError::Run {
            path: self.path.clone(),
            reason: e.to_string(),
        };
        let mut values = Vec::with_capacity(inputs.len());
        for (name, t) in inputs {
            let shape: Vec<i64> = t.shape.iter().map(|&d| d as i64).collect();
            let value = ort::value::Tensor::from_array((shape, t.data)).map_err(run_err)?;
            values.push((
                name.to_string(),
                ort::session::SessionInputValue::from(value),
            ));
        }
        let outputs = self.inner.run(values).map_err(run_err)?;
        let mut result = Vec::with_capacity(outputs.len());
        for (_, value) in outputs.iter() {
            let (shape, data) = value.try_extract_tensor::<f32>().map_err(run_err)?;
            result.push(TensorF32 {
                shape: shape.iter().map(|&d| d as usize).collect(),
                data: data.to_vec(),
            });
        }
        Ok(result)
    }
}

fn shapes(outlets: &[ort::value::Outlet]) -> Vec<(String, Vec<i64>)> {
    outlets
        .iter()
        .map(|o| {
            let shape = match o.dtype() {
                ort::value::ValueType::Tensor { shape, .. } => shape.iter().copied().collect(),
                _ => Vec::new(),
            };
            (o.name().to_string(), shape)
        })
        .collect()
}

/// ONNX Runtime's build info carries no release number, so read it from the library's real file
/// name: `libonnxruntime.so` → (symlink) `libonnxruntime.so.1.32.0` → "1.32.0".
fn version_from_file_name(path: &Path) -> Option<String> {
    let real = std::fs::canonicalize(path).ok()?;
    let name = real.file_name()?.to_str()?;
    let (_, version) = name
        .split_once(".so.")
        .or_else(|| name.split_once("onnxruntime."))?;
    let version = version.trim_end_matches(".dylib").trim_end_matches(".dll");
    (!version.is_empty() && version.chars().all(|c| c.is_ascii_digit() || c == '.'))
        .then(|| version.to_string())
}

fn panic_message(panic: &Box<dyn std::any::Any + Send>) -> String {
    panic
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "the loader panicked".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_version_from_library_file_name() {
        let dir = std::env::temp_dir().join(format!("guava-onnx-version-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let real = dir.join("libonnxruntime.so.1.32.0");
        std::fs::write(&real, b"").expect("write");
        assert_eq!(version_from_file_name(&real).as_deref(), Some("1.32.0"));
        let plain = dir.join("libonnxruntime.so");
        std::fs::write(&plain, b"").expect("write");
        assert_eq!(version_from_file_name(&plain), None);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn missing_library_is_an_error_not_a_panic() {
        let err = OnnxRuntime::load_from(Path::new("/nonexistent/libonnxruntime.so"))
            .expect_err("a missing library must not load");
        assert!(err.to_string().contains("tools/setup.sh"), "{err}");
    }
}
