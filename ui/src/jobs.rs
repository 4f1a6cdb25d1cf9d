//! Work that runs on a worker thread while the window stays live: loading files and making
//! avatars through the library's pipeline. Each job publishes its stage, can be cancelled, and
//! sends back what it [`Loaded`] (or an error naming the file), which the app takes in.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use guava::avatar::Avatar;
use guava::gaussians::GaussianCloud;
use guava::guava_mode::GuavaModels;
use guava::pipeline::{Mode, Outcome, Photo, Pipeline, Tracked};
use guava::progress::Stage;
use guava::tracking::import::Imported;

use crate::avatar_view::{Preview, SourcePreview, TrackedPhoto};
use crate::fidelity::{self, Fidelity};
use crate::offscreen::OffscreenRenderer;
use guava::body::AnyBody;

/// What a worker thread loaded.
pub enum Loaded {
    Cloud(GaussianCloud),
    Body(AnyBody),
    Motion(Imported),
    /// GUAVA's exported networks (GUAVA mode).
    Networks(Box<GuavaModels>),
    /// EHM-Tracker's keypoint models folder, checked by loading it.
    Wholebody(PathBuf),
    /// An avatar file, or a reconstruction (then with what it saw and how long it took).
    Avatar(Box<LoadedAvatar>),
    /// An export finished: what was written.
    Exported(String),
}

/// An avatar as a job hands it over.
pub struct LoadedAvatar {
    pub avatar: Avatar,
    /// The reconstruction's one-line report, when it was made here.
    pub summary: Option<String>,
    /// What the avatar panel shows of the photo.
    pub preview: Preview,
    /// The photo's camera (world→camera, `invtanfov`), when it was made here.
    pub source_camera: Option<(glam::Mat4, f32)>,
    /// How it compares with its photo, when it was made here (or why it could not be compared).
    pub fidelity: Option<Result<Fidelity, String>>,
}

impl LoadedAvatar {
    pub fn file(avatar: Avatar) -> Self {
        Self {
            avatar,
            summary: None,
            preview: Preview::None,
            source_camera: None,
            fidelity: None,
        }
    }
}

/// A job in flight.
pub struct Job {
    pub path: PathBuf,
    pub started: Instant,
    rx: Receiver<Result<Loaded, String>>,
    /// The stage it is in (or its progress), shown beside the spinner.
    stage: Arc<Mutex<String>>,
    /// Set by Cancel; jobs that check it stop at their next stage.
    cancel: Arc<AtomicBool>,
}

/// What a job function gets: where to publish its stage, and whether it was cancelled.
pub struct JobContext<'a> {
    stage: &'a Mutex<String>,
    cancel: &'a AtomicBool,
}

impl JobContext<'_> {
    pub fn set_stage(&self, stage: impl Into<String>) {
        *self.stage.lock().unwrap_or_else(|e| e.into_inner()) = stage.into();
    }

    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// A progress callback for the pipeline: publishes the stage, stops when cancelled.
    pub fn progress(&self) -> impl FnMut(Stage) -> bool + '_ {
        move |s| {
            self.set_stage(s.name());
            !self.cancelled()
        }
    }
}

impl Job {
    /// Runs `work` on a worker thread, `first_stage` shown until it says otherwise.
    pub fn spawn(
        path: PathBuf,
        first_stage: &'static str,
        work: impl FnOnce(&JobContext) -> Result<Loaded, String> + Send + 'static,
    ) -> Self {
        let (tx, rx) = std::sync::mpsc::channel();
        let stage = Arc::new(Mutex::new(first_stage.to_string()));
        let cancel = Arc::new(AtomicBool::new(false));
        let (worker_stage, worker_cancel) = (stage.clone(), cancel.clone());
        std::thread::spawn(move || {
            let context = JobContext {
                stage: &worker_stage,
                cancel: &worker_cancel,
            };
            // The receiver is gone if the user cancelled: nothing to do then.
            let _ = tx.send(work(&context));
        });
        Self {
            path,
            started: Instant::now(),
            rx,
            stage,
            cancel,
        }
    }

    pub fn stage(&self) -> String {
        self.stage.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    /// The job's result once it is done.
    pub fn poll(&self) -> Option<Result<Loaded, String>> {
        match self.rx.try_recv() {
            Err(TryRecvError::Empty) => None,
            Err(TryRecvError::Disconnected) => Some(Err(format!(
                "{}: loading stopped unexpectedly",
                self.path.display()
            ))),
            Ok(result) => Some(result),
        }
    }
}

/// What making an avatar of a photo needs from the app, moved to its worker.
pub struct PhotoJob {
    pub body: Arc<AnyBody>,
    pub networks: Option<Arc<Mutex<GuavaModels>>>,
    /// EHM-Tracker's keypoint models folder, when the user chose it.
    pub dwpose: Option<PathBuf>,
    /// The session's pipeline (keypoint models, UV map), kept between photos.
    pub pipeline: Arc<Mutex<Pipeline>>,
    /// The viewer's device, to compare the avatar with its photo (none without a device).
    pub offscreen: Option<Arc<Mutex<OffscreenRenderer>>>,
}

impl PhotoJob {
    /// The default reconstruction on a template body, GUAVA's on an EHM body.
    pub fn run(&self, photo: Photo, tracked: Tracked, job: &JobContext) -> Result<Loaded, String> {
        // One job runs at a time, so holding the pipeline for the whole job blocks nobody.
        let mut pipeline = self.pipeline.lock().unwrap_or_else(|e| e.into_inner());
        pipeline.keypoints.set_dwpose(self.dwpose.clone());
        let file = match &photo {
            Photo::File(path) => Some(path.to_path_buf()),
            Photo::Pixels { .. } => None,
        };
        let mut progress = job.progress();
        let outcome = match &*self.body {
            AnyBody::Template(body) => {
                pipeline.reconstruct(Mode::Default(body), photo, tracked, &mut progress)
            }
            AnyBody::Ehm(body) => {
                let networks = self.networks.as_deref().ok_or_else(|| {
                    format!(
                        "{}: GUAVA mode needs GUAVA's networks: open their folder (Mode > \
                         Networks folder…, written by tools/export_guava_onnx.py)",
                        file.as_deref().unwrap_or(Path::new("photo")).display()
                    )
                })?;
                let mut networks = networks.lock().unwrap_or_else(|e| e.into_inner());
                let mode = Mode::Guava {
                    body,
                    networks: &mut networks,
                };
                pipeline.reconstruct(mode, photo, tracked, &mut progress)
            }
        }
        .map_err(|e| e.to_string())?;
        job.set_stage("comparing with the photo");
        let fidelity = self.compare(&outcome);
        Ok(self.loaded(outcome, fidelity, file.as_deref()))
    }

    /// The avatar rendered from its photo's camera against the photo (`guava eval`), on the
    /// body it was made on.
    fn compare(&self, outcome: &Outcome) -> Option<Result<Fidelity, String>> {
        let offscreen = self.offscreen.as_ref()?;
        let mut offscreen = offscreen.lock().unwrap_or_else(|e| e.into_inner());
        let (avatar, view, photo) = (&outcome.avatar, &outcome.view, &outcome.photo);
        let compared = match &*self.body {
            AnyBody::Ehm(body) if avatar.ehm_identity.is_some() => {
                let mut tracked = body.clone();
                avatar.apply_ehm_identity(&mut tracked);
                fidelity::measure(&mut offscreen, avatar, &*tracked, view, photo)
            }
            body => fidelity::measure(&mut offscreen, avatar, body, view, photo),
        };
        Some(compared.map_err(|e| e.to_string()))
    }

    /// The avatar with its summary, its photo's camera and what the panel shows of the photo:
    /// the keypoints and the fit (or, for a GUAVA-mode avatar made from its tracking, the
    /// tracked body over the photo).
    fn loaded(
        &self,
        outcome: Outcome,
        fidelity: Option<Result<Fidelity, String>>,
        photo: Option<&Path>,
    ) -> Loaded {
        let Outcome {
            avatar,
            view,
            report,
            ..
        } = outcome;
        let camera = (view.camera.view_from_world, view.camera.invtanfov());
        let body = &*self.body;
        let preview = match (photo, body, &report.fit) {
            (None, ..) => None,
            (Some(photo), AnyBody::Template(b), fit) => SourcePreview::new(
                body,
                &b.landmarks,
                photo,
                &report.keypoints,
                fit.as_ref(),
                view,
            )
            .map(|p| Preview::Fit(Box::new(p))),
            (Some(photo), AnyBody::Ehm(_), Some(fit)) => SourcePreview::new(
                body,
                &fit.surface,
                photo,
                &report.keypoints,
                Some(fit),
                view,
            )
            .map(|p| Preview::Fit(Box::new(p))),
            (Some(photo), AnyBody::Ehm(_), None) => {
                TrackedPhoto::new(photo, &view, body).map(Preview::Tracked)
            }
        };
        Loaded::Avatar(Box::new(LoadedAvatar {
            avatar,
            summary: Some(report.summary()),
            preview: preview.unwrap_or(Preview::None),
            source_camera: Some(camera),
            fidelity,
        }))
    }
}
