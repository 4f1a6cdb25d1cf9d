//! Work that runs on a worker thread while the window stays live: loading files, making avatars
//! through the library's pipeline, exports. [`Jobs`] runs one at a time and queues the files
//! waiting to open; each job publishes its stage, can be cancelled, and sends back what it
//! [`Loaded`] (or an error naming the file) as a message the app takes in.

use std::collections::VecDeque;
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
}

/// A job's work: runs on the worker, publishes its stage and checks Cancel through its context,
/// and answers with `T` or an error naming the file.
pub type Work<T> = dyn FnOnce(&JobContext) -> Result<T, String> + Send;

/// What a finished job sends back (its message to the app).
pub enum Done {
    /// Something to open: taken into the document.
    Opened(Loaded),
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

/// The jobs controller: the job in flight (one at a time, so a photo's reconstruction never
/// races an export for the pipeline or the device) and the files waiting to open.
#[derive(Default)]
pub struct Jobs {
    running: Option<Job>,
    queue: VecDeque<PathBuf>,
}

impl Jobs {
    /// Whether a job runs or a file waits to open.
    pub fn busy(&self) -> bool {
        self.running.is_some() || !self.queue.is_empty()
    }

    pub fn running(&self) -> Option<&Job> {
        self.running.as_ref()
    }

    /// Runs `work` on a worker thread, `first_stage` shown until it says otherwise; refused
    /// (before anything starts) while another job runs.
    pub fn spawn(
        &mut self,
        path: PathBuf,
        first_stage: &'static str,
        work: impl FnOnce(&JobContext) -> Result<Done, String> + Send + 'static,
    ) -> Result<(), String> {
        if self.running.is_some() {
            return Err(format!(
                "{}: another job is running: wait for it or cancel it",
                path.display()
            ));
        }
        self.running = Some(Job::spawn(path, first_stage, work));
        Ok(())
    }

    /// Stops the running job at its next step; the file it was working on.
    pub fn cancel(&mut self) -> Option<PathBuf> {
        let job = self.running.take()?;
        job.cancel();
        Some(job.path)
    }

    /// The running job's message once it is done: its file and what it loaded (or the error).
    pub fn finished(&mut self) -> Option<(PathBuf, Result<Done, String>)> {
        let result = self.running.as_ref()?.poll()?;
        let job = self.running.take()?;
        Some((job.path, result))
    }

    /// Files to open one after another.
    pub fn enqueue(&mut self, paths: impl IntoIterator<Item = PathBuf>) {
        self.queue.extend(paths);
    }

    /// The next file to open, once no job runs.
    pub fn next_queued(&mut self) -> Option<PathBuf> {
        match self.running {
            Some(_) => None,
            None => self.queue.pop_front(),
        }
    }
}

/// A job in flight.
pub struct Job {
    pub path: PathBuf,
    pub started: Instant,
    rx: Receiver<Result<Done, String>>,
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
    fn spawn(
        path: PathBuf,
        first_stage: &'static str,
        work: impl FnOnce(&JobContext) -> Result<Done, String> + Send + 'static,
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

    fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    /// The job's result once it is done.
    fn poll(&self) -> Option<Result<Done, String>> {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn wait(jobs: &mut Jobs) -> (PathBuf, Result<Done, String>) {
        loop {
            if let Some(done) = jobs.finished() {
                return done;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }

    /// One job at a time: a second is refused before it starts (its work never runs), queued
    /// files wait for the running job, and the finished job's message names its file.
    #[test]
    fn one_job_at_a_time_and_queued_files_wait() {
        let mut jobs = Jobs::default();
        let (release, gate) = std::sync::mpsc::channel::<()>();
        jobs.spawn("a".into(), "first", move |_| {
            gate.recv().map_err(|e| e.to_string())?;
            Ok(Done::Exported("a written".into()))
        })
        .expect("nothing runs yet");
        let ran = Arc::new(AtomicBool::new(false));
        let flag = ran.clone();
        let refused = jobs.spawn("b".into(), "second", move |_| {
            flag.store(true, Ordering::Relaxed);
            Ok(Done::Exported("b".into()))
        });
        assert!(
            refused
                .expect_err("a runs")
                .contains("another job is running")
        );
        jobs.enqueue(["c".into(), "d".into()]);
        assert_eq!(jobs.next_queued(), None, "a still runs");
        assert_eq!(jobs.running().map(Job::stage).as_deref(), Some("first"));
        release.send(()).expect("a waits");
        let (path, done) = wait(&mut jobs);
        assert_eq!(path, PathBuf::from("a"));
        assert!(matches!(done, Ok(Done::Exported(m)) if m == "a written"));
        assert_eq!(jobs.next_queued(), Some("c".into()));
        assert_eq!(jobs.next_queued(), Some("d".into()));
        assert!(!jobs.busy());
        assert!(!ran.load(Ordering::Relaxed), "the refused job never ran");
    }

    /// Cancel stops the job at its next check and forgets it: its message never arrives.
    #[test]
    fn cancel_stops_the_job_at_its_next_check() {
        let mut jobs = Jobs::default();
        let (stopped_tx, stopped) = std::sync::mpsc::channel();
        jobs.spawn("long".into(), "working", move |context| {
            while !context.cancelled() {
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            let _ = stopped_tx.send(());
            Err("cancelled".into())
        })
        .expect("starts");
        assert_eq!(jobs.cancel(), Some(PathBuf::from("long")));
        stopped
            .recv_timeout(std::time::Duration::from_secs(10))
            .expect("the worker saw the cancel");
        assert!(jobs.finished().is_none() && !jobs.busy());
    }
}
