//! Driving the body live from a video or a webcam (*Drive* menu). Two worker threads: one reads
//! frames at the video's own pace (a camera delivers them at its own), keeping only the
//! latest; the other tracks the latest frame it has not tracked yet (`guava::track::Tracker`:
//! MediaPipe's models in tracking mode, the fit warm-started from the last solve), skipping
//! those it had no time for. The UI never waits on either: each frame it poses the body from
//! the latest solve, shows the latest picture in a corner of the viewport and says how many
//! frames the solve is behind it. Control groups touched by hand still override the pose (as
//! with a motion file), and the solves can be recorded and saved as a tracking file.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use guava::body::{BodyModel, BodyPose, Posable};
use guava::pipeline::Pipeline;
use guava::track::Tracker;
use guava::tracking::{Frame, Retarget, Tracking};
use guava::video::{FrameSource, VideoFrame};
use image::RgbaImage;

/// Where frames come from.
pub enum DriveSource {
    /// A video file or a folder of frames, played at its own rate.
    File(PathBuf),
    /// A camera (the `webcam` cargo feature), by index.
    #[cfg(feature = "webcam")]
    Webcam(u32),
}

/// What the workers share with the UI.
#[derive(Default)]
struct Live {
    /// The newest frame read: its index, time and pixels.
    latest: Option<(usize, f64, Arc<RgbaImage>)>,
    /// The tracking file's header once a person was found.
    header: Option<Tracking>,
    /// The newest solve: the index and time of the frame it is of, and the frame.
    solved: Option<(usize, f64, Frame)>,
    /// Every solve since recording started, in order.
    recorded: Vec<(f64, Frame)>,
    recording: bool,
    /// Why nothing is tracked yet (no person found yet), or what went wrong.
    waiting: Option<String>,
    error: Option<String>,
    /// The source has no more frames (and every one the tracker took is tracked).
    read_all: bool,
    tracked_all: bool,
    /// The last solve's time, the frame rate of the source, solves a second.
    solve_ms: f32,
    source_fps: f32,
    solves: usize,
}

/// A live drive: the workers and what the UI has taken from them.
pub struct Drive {
    /// What drives the body, for the panel.
    pub label: String,
    shared: Arc<(Mutex<Live>, Condvar)>,
    stop: Arc<AtomicBool>,
    workers: Vec<JoinHandle<()>>,
    started: Instant,
    /// The solve's header as a one-frame tracking (its frame replaced by each solve) and its
    /// mapping onto the body; `None` until the header arrives.
    sampler: Option<(Tracking, Retarget)>,
    /// The index of the solve last written into the pose.
    applied: Option<usize>,
    /// The picture last uploaded for the corner view.
    picture: Option<(usize, egui::TextureHandle)>,
}

impl Drive {
    /// Starts reading `source` and tracking it.
    pub fn start(source: DriveSource) -> Self {
        let label = match &source {
            DriveSource::File(path) => format!("video {}", path.display()),
            #[cfg(feature = "webcam")]
            DriveSource::Webcam(i) => format!("webcam {i}"),
        };
        let shared = Arc::new((Mutex::new(Live::default()), Condvar::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let reader = {
            let (shared, stop) = (shared.clone(), stop.clone());
            std::thread::spawn(move || read(source, &shared, &stop))
        };
        let tracker = {
            let (shared, stop) = (shared.clone(), stop.clone());
            std::thread::spawn(move || track(&shared, &stop))
        };
        Self {
            label,
            shared,
            stop,
            workers: vec![reader, tracker],
            started: Instant::now(),
            sampler: None,
            applied: None,
            picture: None,
        }
    }

    fn live(&self) -> std::sync::MutexGuard<'_, Live> {
        self.shared.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Whether frames are still coming or being tracked.
    pub fn running(&self) -> bool {
        let live = self.live();
        live.error.is_none() && !(live.read_all && live.tracked_all)
    }

    /// Writes the newest solve into `pose` (the pose a motion would write), mapped onto `body`;
    /// returns whether it changed. The tracked person's shape is not applied: the avatar keeps
    /// its own.
    pub fn update(&mut self, body: &impl Posable, pose: &mut BodyPose) -> bool {
        let (header, solved) = {
            let live = self.live();
            let header = match &self.sampler {
                None => live.header.clone(),
                Some(_) => None,
            };
            (header, live.solved.clone())
        };
        if let Some(mut header) = header {
            header.identity.parameters.clear();
            header.identity.ehm = None;
            let retarget = Retarget::new(&header, body);
            self.sampler = Some((header, retarget));
        }
        let (Some((tracking, retarget)), Some((index, _, frame))) = (&mut self.sampler, solved)
        else {
            return false;
        };
        if self.applied == Some(index) {
            return false;
        }
        tracking.frames = vec![frame];
        retarget.sample(tracking, 0.0, pose);
        self.applied = Some(index);
        true
    }

    /// How many frames the pose shown is behind the newest frame read.
    pub fn latency_frames(&self) -> Option<usize> {
        let live = self.live();
        let (newest, _, _) = live.latest.as_ref()?;
        let (solved, _, _) = live.solved.as_ref()?;
        Some(newest.saturating_sub(*solved))
    }

    /// The last solve's time and solves per second since the start.
    pub fn rates(&self) -> (f32, f32) {
        let live = self.live();
        let secs = self.started.elapsed().as_secs_f32().max(1e-3);
        (live.solve_ms, live.solves as f32 / secs)
    }

    /// Why the body is not driven yet, or what failed.
    pub fn message(&self) -> Option<(String, bool)> {
        let live = self.live();
        match (&live.error, &live.waiting) {
            (Some(e), _) => Some((e.clone(), true)),
            (None, Some(w)) => Some((format!("looking for a person: {w}"), false)),
            _ => None,
        }
    }

    pub fn solves(&self) -> usize {
        self.live().solves
    }

    /// Starts keeping every solve (dropping what an earlier recording kept) or stops.
    pub fn set_recording(&self, on: bool) {
        let mut live = self.live();
        if on && !live.recording {
            live.recorded.clear();
        }
        live.recording = on;
    }

    pub fn recording(&self) -> bool {
        self.live().recording
    }

    /// Solves recorded so far.
    pub fn recorded(&self) -> usize {
        self.live().recorded.len()
    }

    /// The recording as a tracking file at the source's frame rate: each frame the newest
    /// solve at its time (frames the tracker had no time for hold the last solve). `None`
    /// before a solve was recorded.
    pub fn recording_as_tracking(&self) -> Option<Tracking> {
        let live = self.live();
        let header = live.header.as_ref()?;
        let (first, _) = live.recorded.first()?;
        let (last, _) = live.recorded.last()?;
        let fps = if live.source_fps > 0.0 {
            live.source_fps
        } else {
            30.0
        };
        let count = ((last - first) * f64::from(fps)).round() as usize + 1;
        let mut frames = Vec::with_capacity(count);
        let mut next = 0;
        for k in 0..count {
            let t = first + k as f64 / f64::from(fps) + 1e-6;
            while next + 1 < live.recorded.len() && live.recorded[next + 1].0 <= t {
                next += 1;
            }
            frames.push(live.recorded[next].1.clone());
        }
        Some(Tracking {
            fps,
            frames,
            ..header.clone()
        })
    }

    /// The newest picture read, uploaded for the corner view when it changed.
    pub fn picture(&mut self, ctx: &egui::Context) -> Option<&egui::TextureHandle> {
        let latest = self.live().latest.clone();
        if let Some((index, _, pixels)) = latest
            && self.picture.as_ref().is_none_or(|(i, _)| *i != index)
        {
            let size = [pixels.width() as usize, pixels.height() as usize];
            let image = egui::ColorImage::from_rgba_unmultiplied(size, pixels.as_raw());
            match &mut self.picture {
                Some((i, texture)) => {
                    texture.set(image, egui::TextureOptions::LINEAR);
                    *i = index;
                }
                None => {
                    let texture =
                        ctx.load_texture("drive picture", image, egui::TextureOptions::LINEAR);
                    self.picture = Some((index, texture));
                }
            }
        }
        self.picture.as_ref().map(|(_, t)| t)
    }
}

impl Drop for Drive {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        self.shared.1.notify_all();
        for worker in self.workers.drain(..) {
            let _ = worker.join();
        }
    }
}

/// The reader: frames at the source's pace, the newest kept for the tracker and the UI.
fn read(source: DriveSource, shared: &(Mutex<Live>, Condvar), stop: &AtomicBool) {
    let (live, wake) = shared;
    let lock = || live.lock().unwrap_or_else(|e| e.into_inner());
    let opened: Result<Box<dyn FrameSource>, String> = match source {
        DriveSource::File(path) => guava::video::open(&path, 30.0)
            .map(|f| f as Box<dyn FrameSource>)
            .map_err(|e| e.to_string()),
        #[cfg(feature = "webcam")]
        DriveSource::Webcam(index) => guava::video::webcam::Webcam::open(index)
            .map(|w| Box::new(w) as Box<dyn FrameSource>)
            .map_err(|e| e.to_string()),
    };
    let mut frames = match opened {
        Ok(frames) => frames,
        Err(e) => {
            lock().error = Some(e);
            wake.notify_all();
            return;
        }
    };
    // A file plays in real time; a camera's frames come when they come.
    let paced = frames.info().frames.is_some();
    lock().source_fps = frames.info().fps;
    let started = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        let Some(frame) = frames.next_frame() else {
            break;
        };
        match frame {
            Ok(VideoFrame {
                index,
                time_s,
                pixels,
            }) => {
                if paced {
                    let due = Duration::from_secs_f64(time_s.max(0.0));
                    if let Some(wait) = due.checked_sub(started.elapsed()) {
                        std::thread::sleep(wait);
                    }
                }
                lock().latest = Some((index, time_s, Arc::new(pixels)));
                wake.notify_all();
            }
            Err(e) => {
                lock().error = Some(e.to_string());
                break;
            }
        }
    }
    lock().read_all = true;
    wake.notify_all();
}

/// The tracker: the newest frame not tracked yet, each in turn, until the reader is done.
fn track(shared: &(Mutex<Live>, Condvar), stop: &AtomicBool) {
    let (live, wake) = shared;
    let lock = || live.lock().unwrap_or_else(|e| e.into_inner());
    let fail = |e: String| {
        lock().error = Some(e);
        wake.notify_all();
    };
    let body = match BodyModel::default_body() {
        Ok(body) => body,
        Err(e) => return fail(e.to_string()),
    };
    // Its own keypoint models: a photo reconstructed meanwhile does not wait for the drive.
    let mut pipeline = Pipeline::default();
    if let Err(e) = pipeline.landmarkers() {
        return fail(e);
    }
    let mut tracker: Option<Tracker> = None;
    let mut last = None;
    loop {
        let next = {
            let mut guard = lock();
            loop {
                if stop.load(Ordering::Relaxed) || guard.error.is_some() {
                    return;
                }
                match &guard.latest {
                    Some((index, time, pixels)) if Some(*index) != last => {
                        break (*index, *time, pixels.clone(), guard.source_fps);
                    }
                    _ if guard.read_all => {
                        guard.tracked_all = true;
                        return;
                    }
                    _ => {
                        guard = wake
                            .wait_timeout(guard, Duration::from_millis(100))
                            .map(|(g, _)| g)
                            .unwrap_or_else(|e| e.into_inner().0);
                    }
                }
            }
        };
        let (index, time_s, pixels, fps) = next;
        last = Some(index);
        let tracker = tracker.get_or_insert_with(|| Tracker::new("the live video", fps, &[true]));
        let started = Instant::now();
        let frame = VideoFrame {
            index,
            time_s,
            pixels: RgbaImage::clone(&pixels),
        };
        let result = tracker.track(&body, &mut pipeline, &frame);
        let mut guard = lock();
        match result {
            Ok(Ok(track)) => {
                let solved = track.frames.into_iter().next().expect("one setting");
                if guard.header.is_none() {
                    guard.header = tracker.header().cloned();
                }
                if guard.recording {
                    guard.recorded.push((time_s, solved.clone()));
                }
                guard.solved = Some((index, time_s, solved));
                guard.waiting = None;
                guard.solve_ms = started.elapsed().as_secs_f32() * 1e3;
                guard.solves += 1;
            }
            Ok(Err(why)) => guard.waiting = Some(why),
            Err(e) => {
                guard.error = Some(e.to_string());
                return;
            }
        }
    }
}
