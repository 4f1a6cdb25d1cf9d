//! The refiner pass in the viewer: the user's switches, and the refiner itself, loaded on a
//! worker (the default one, or GUAVA's for GUAVA-mode avatars; run by ONNX Runtime on the CPU
//! or our WGSL passes on the viewer's device, `RefinerOn`). The view renderer refines the frame
//! on screen with it ([`RefineWith`]) once the view settles (no drag, no playback) and presents
//! the refined picture until anything changes; while the user drags or plays the raw splat is
//! shown — unless refining *while interacting* too, when the latest refined picture stays on
//! screen (behind the input by the refiner's time) until the next is ready. Exports refine with
//! the same loaded refiner.

use guava::avatar::AvatarKind;
use guava::gpu::GpuContext;
use guava::refine::{Refiner, RefinerOn, SharedRefiner};
use guava::view::RefineWith;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, TryRecvError};

pub struct RefinedView {
    /// Whether the refiner runs when the view settles (the user's switch).
    pub enabled: bool,
    /// Whether it also runs while the user drags or plays, showing its latest picture meanwhile.
    pub while_interacting: bool,
    /// Where it runs (the user's choice).
    pub on: RefinerOn,
    /// The loaded refiner, shared with the view renderer, its workers and exports.
    pub refiner: SharedRefiner,
    loading: Option<Loading>,
    /// The last error (shown in the display panel; refining is switched off by it).
    pub error: Option<String>,
    /// Why the avatar on screen has no refiner to run (shown in the display panel).
    pub unavailable: Option<String>,
}

/// A refiner being loaded on a worker: which, and the outcome.
struct Loading {
    path: PathBuf,
    on: RefinerOn,
    outcome: Receiver<Result<(), String>>,
}

impl Default for RefinedView {
    fn default() -> Self {
        Self {
            enabled: true,
            while_interacting: false,
            on: RefinerOn::Auto,
            refiner: SharedRefiner::default(),
            loading: None,
            error: None,
            unavailable: None,
        }
    }
}

impl RefinedView {
    /// What the view refines with for the refiner at `path`: loads it first on a worker (the
    /// view shows the raw splat meanwhile). `behind`: the user interacts, show the latest
    /// refined picture until the next is made.
    pub fn with(
        &mut self,
        ctx: &egui::Context,
        gpu: &GpuContext,
        path: &Path,
        behind: bool,
    ) -> Option<RefineWith> {
        self.load(ctx, gpu, path);
        let ctx = ctx.clone();
        self.enabled.then(|| RefineWith {
            refiner: self.refiner.clone(),
            path: path.to_path_buf(),
            on: self.on,
            behind,
            wake: Some(Arc::new(move || ctx.request_repaint())),
        })
    }

    /// Starts loading the refiner at `path` (for where it should run) unless it is loaded or
    /// loading; takes the outcome of a load.
    fn load(&mut self, ctx: &egui::Context, gpu: &GpuContext, path: &Path) {
        if let Some(loading) = &self.loading {
            match loading.outcome.try_recv() {
                Err(TryRecvError::Empty) if loading.path == path && loading.on == self.on => {
                    return;
                }
                Ok(Err(e)) => {
                    self.error = Some(e);
                    self.enabled = false;
                    self.loading = None;
                    return;
                }
                // Loaded, the worker gone, or loading another one (let it finish first).
                Err(TryRecvError::Empty) => return,
                _ => self.loading = None,
            }
        }
        let loaded = match self.refiner.try_lock() {
            Ok(guard) => guard
                .as_ref()
                .is_some_and(|r| r.path == path && r.on == self.on),
            // Busy refining: it is the one asked for, or will be asked again next frame.
            Err(_) => true,
        };
        if loaded {
            return;
        }
        let (tx, rx) = std::sync::mpsc::channel();
        let (refiner, gpu, ctx) = (self.refiner.clone(), gpu.clone(), ctx.clone());
        let (file, on) = (path.to_path_buf(), self.on);
        std::thread::spawn(move || {
            let mut slot = refiner.lock().unwrap_or_else(|e| e.into_inner());
            let loaded = Refiner::load_on(on, &gpu, &file).map_err(|e| e.to_string());
            let outcome = loaded.map(|r| *slot = Some(r));
            drop(slot);
            // The receiver is gone if the viewer closed: nothing to do then.
            let _ = tx.send(outcome);
            ctx.request_repaint();
        });
        self.loading = Some(Loading {
            path: path.to_path_buf(),
            on: self.on,
            outcome: rx,
        });
    }

    /// What an export refines with: the refiner for `kind` (the view's, loaded by the export's
    /// worker unless the view has already), when the view refines.
    pub fn for_export(&self, kind: AvatarKind, networks: Option<&Path>) -> Option<RefineWith> {
        let path = guava::refine::refiner_for(kind, networks).ok();
        self.enabled.then_some(()).and(path).map(|path| RefineWith {
            refiner: self.refiner.clone(),
            path,
            on: self.on,
            behind: false,
            wake: None,
        })
    }

    /// Takes an error the view renderer met refining: shown, and refining switched off.
    pub fn failed(&mut self, error: String) {
        self.error = Some(error);
        self.enabled = false;
    }
}
