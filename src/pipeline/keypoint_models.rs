//! The keypoint models a session fits and masks photos with: MediaPipe's seven (shipped, or a
//! folder of the user's with the same files), optionally with EHM-Tracker's YOLOX + DWPose for
//! the body and hand points. Loaded by the first photo that needs them and kept for the next
//! (MediaPipe's take ~0.4 s to load, EHM-Tracker's are hundreds of MB); choosing other
//! EHM-Tracker models loads or drops only those.

use std::path::{Path, PathBuf};

use crate::keypoints::{Landmarkers, MODELS_DIR, Wholebody};
use crate::onnx::OnnxRuntime;

#[derive(Default)]
pub struct KeypointModels {
    /// MediaPipe's models from this folder instead of the shipped ones.
    dir: Option<PathBuf>,
    /// EHM-Tracker's checkpoint folder the next photo wants (`None`: MediaPipe's alone).
    dwpose: Option<PathBuf>,
    loaded: Option<Landmarkers>,
    /// The EHM-Tracker folder `loaded` holds the models of.
    loaded_dwpose: Option<PathBuf>,
}

impl KeypointModels {
    /// MediaPipe's models from `dir` (`None`: the shipped ones), with EHM-Tracker's from `dwpose`.
    pub fn new(dir: Option<PathBuf>, dwpose: Option<PathBuf>) -> Self {
        Self {
            dir,
            dwpose,
            ..Self::default()
        }
    }

    /// Fit photos with EHM-Tracker's models from `dir` from now on (`None`: MediaPipe's alone).
    pub fn set_dwpose(&mut self, dir: Option<PathBuf>) {
        self.dwpose = dir;
    }

    pub fn dwpose(&self) -> Option<&Path> {
        self.dwpose.as_deref()
    }

    /// Whether the models a call to [`Self::load`] gives are loaded already.
    pub fn is_loaded(&self) -> bool {
        self.loaded.is_some() && self.loaded_dwpose == self.dwpose
    }

    /// The models, loading what is not loaded yet. Consistent when loading fails: no
    /// EHM-Tracker models then, and none recorded.
    pub fn load(&mut self) -> Result<&mut Landmarkers, String> {
        let runtime = OnnxRuntime::load().map_err(|e| e.to_string())?;
        if self.loaded.is_none() {
            self.loaded_dwpose = None;
            let dir = self.dir.as_deref().unwrap_or(Path::new(MODELS_DIR));
            self.loaded = Some(Landmarkers::load_dir(runtime, dir).map_err(|e| e.to_string())?);
        }
        let models = self.loaded.as_mut().expect("loaded above");
        if self.loaded_dwpose != self.dwpose {
            models.wholebody = None;
            self.loaded_dwpose = None;
            if let Some(dir) = &self.dwpose {
                models.wholebody =
                    Some(Wholebody::load_dir(runtime, dir).map_err(|e| e.to_string())?);
            }
            self.loaded_dwpose = self.dwpose.clone();
        }
        Ok(models)
    }
}
