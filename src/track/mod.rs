//! Tracking a video of a person into a tracking file (`guava track`, the viewer's live driving,
//! `guava eval --video`): the first frame that shows a person is framed and fitted as a photo
//! is (the clip's square, the body's shape, the face's features: its identity), then every
//! frame is seen by MediaPipe's models in tracking mode ([`LandmarkTracker`]), its points
//! filtered (One Euro, [`filter`]), the body fitted from the last frame's fit with a temporal
//! prior ([`crate::fit::fit_frame`]) and the fit's output filtered, rotations as quaternions
//! ([`Solver`]). A frame where the person cannot be fitted holds the last pose.
//!
//! The two halves are apart ([`Seer`]: decoded frame → the models' points; [`Fitter`]: points →
//! pose), so that a video's next frame is seen while this one is fitted ([`track_video`] runs
//! them on two threads).

mod accuracy;
pub mod filter;
mod jitter;
mod landmarks;
mod solve;

pub use accuracy::{AccuracyError, COMPARED_JOINTS, joint_errors};
pub use jitter::Jitter;
pub use landmarks::{LandmarkTracker, MODEL_PARTS, ModelRuns};
pub use solve::Solver;

use std::time::{Duration, Instant};

use crate::body::BodyRef;
use crate::body::{BodyModel, HEAD_SIZE};
use crate::fit::{FaceEmbedding, FitState, embed_face};
use crate::keypoints::Detections;
use crate::photo::{Crop, SOURCE_SIZE, SourceImage};
use crate::pipeline::{Framing, Photo, Pipeline, Tracked};
use crate::progress::Stage;
use crate::reconstruct::ReconstructError;
use crate::tracking::{Frame, SourceView, Tracking};
use crate::video::{FrameSource, VideoError, VideoFrame};

#[derive(Debug, thiserror::Error)]
pub enum TrackError {
    #[error(transparent)]
    Video(#[from] VideoError),
    #[error(transparent)]
    Source(#[from] ReconstructError),
    #[error("keypoint models: {0}")]
    Models(String),
    #[error("{file}: no frame shows a person the fit can use (the last try: {reason})")]
    NoPerson { file: String, reason: String },
    #[error("cancelled")]
    Cancelled,
}

/// A clip's first frame with a person, fitted as a photo: what the rest of the clip keeps.
#[derive(Clone, Debug)]
pub struct ClipStart {
    /// The fit (pose, camera, and the square of the frame it sees).
    pub view: SourceView,
    /// The fit's state, with the face's feature offsets.
    pub state: FitState,
    pub embedding: Option<FaceEmbedding>,
    /// The tracking file's header: channels and identity, no frames.
    pub header: Tracking,
    pub detections: Detections,
    pub time_s: f64,
    pub models: Duration,
    pub fit: Duration,
}

/// One frame as the models saw it.
#[derive(Clone, Debug)]
pub struct SeenFrame {
    pub time_s: f64,
    /// In the clip's square at [`SOURCE_SIZE`].
    pub detections: Detections,
    pub runs: ModelRuns,
    /// Time in the keypoint models, with the frame's crop and resize.
    pub models: Duration,
    /// Of which the frame's crop and resize to the models' source square.
    pub prepare: Duration,
}

/// What the models made of a frame.
#[derive(Clone, Debug)]
pub enum Seen {
    /// Nobody the fit can use yet (why).
    NoPerson(String),
    /// The clip starts here.
    Start(Box<ClipStart>),
    Frame(Box<SeenFrame>),
}

/// The models' half of tracking: the clip's square, and where each model looks next.
pub struct Seer {
    name: String,
    fps: f32,
    landmarks: LandmarkTracker,
    /// Once the clip has started: the square of its frames (`None` inside: the centred one).
    crop: Option<Option<Crop>>,
}

impl Seer {
    /// `name` names the video in errors and the tracking file; `fps` is its frame rate.
    pub fn new(name: &str, fps: f32) -> Self {
        Self {
            name: name.into(),
            fps,
            landmarks: LandmarkTracker::default(),
            crop: None,
        }
    }

    /// Sees `frame`: before a person has been found, the frame is framed and fitted as a photo;
    /// after, the models run in tracking mode in the clip's square.
    pub fn see(
        &mut self,
        body: &BodyModel,
        pipeline: &mut Pipeline,
        frame: &VideoFrame,
    ) -> Result<Seen, TrackError> {
        let Some(crop) = self.crop else {
            return self.start(body, pipeline, frame);
        };
        let started = Instant::now();
        let image = SourceImage::from_rgba_at(&frame.pixels, crop, false, &self.name, SOURCE_SIZE)
            .map_err(ReconstructError::from)?;
        let prepare = started.elapsed();
        let models = pipeline.landmarkers().map_err(TrackError::Models)?;
        let (detections, runs) = self
            .landmarks
            .detect(models, &image)
            .map_err(|e| TrackError::Models(e.to_string()))?;
        Ok(Seen::Frame(Box::new(SeenFrame {
            time_s: frame.time_s,
            detections,
            runs,
            models: started.elapsed(),
            prepare,
        })))
    }

    fn start(
        &mut self,
        body: &BodyModel,
        pipeline: &mut Pipeline,
        frame: &VideoFrame,
    ) -> Result<Seen, TrackError> {
        let started = Instant::now();
        let photo = Photo::Pixels {
            name: &self.name,
            pixels: frame.pixels.clone(),
            has_alpha: false,
        };
        let source = match pipeline.source(
            BodyRef::Template(body),
            photo,
            Tracked::Fit,
            Framing::KeepCentred,
            &mut |_| true,
        ) {
            Ok(source) => source,
            // The photo path's refusals (nobody, too few points) say the person is not there
            // yet; anything else (models that do not load) is an error.
            Err(ReconstructError::Photo(e)) => return Ok(Seen::NoPerson(e.problem)),
            Err(e) => return Err(e.into()),
        };
        let models = pipeline.landmarkers().map_err(TrackError::Models)?;
        let embedding = embed_face(body, &mut models.face).ok();
        let detections = source
            .photo
            .detections
            .clone()
            .expect("a fitted photo's detections");
        let fit = source.report.fit.as_ref().expect("a fitted photo's fit");
        let mut state = FitState::of_view(&source.view);
        if let Some(face) = &fit.face {
            state.feature_offsets = face.feature_offsets;
            // The head's size as the face stage fitted it: the photo's silhouette stage, which
            // fits every shape target to the outline, moved it (−0.17 → −0.05 on the
            // synthetic clip), and held there the video's later faces fitted as smiles and
            // a closed jaw where the jaw was open.
            if let (Some(size), Some(t)) = (face.head_size, body.target_index(HEAD_SIZE)) {
                state.pose.coefficients[t] = size;
            }
        }
        let view = SourceView {
            pose: state.pose.clone(),
            ..source.view.clone()
        };
        self.landmarks.seed(&detections, &source.photo.image);
        self.crop = Some(view.crop);
        let mut header = view.to_tracking(
            body,
            &format!(
                "tracked by guava-rs from {} (MediaPipe's landmarks, the default body fitted \
                 frame by frame)",
                self.name
            ),
        );
        header.frames.clear();
        header.fps = self.fps;
        let fit_time = source
            .report
            .timings
            .iter()
            .filter(|(s, _)| matches!(s, Stage::Fit | Stage::Silhouette))
            .map(|(_, d)| *d)
            .sum();
        Ok(Seen::Start(Box::new(ClipStart {
            view,
            state,
            embedding,
            header,
            detections,
            time_s: frame.time_s,
            models: started.elapsed().saturating_sub(fit_time),
            fit: fit_time,
        })))
    }
}

/// One frame's tracking.
#[derive(Clone, Debug)]
pub struct FrameTrack {
    /// This frame as each solver has it (in the order of [`Fitter::start`]'s settings).
    pub frames: Vec<Frame>,
    /// The poses behind `frames`.
    pub views: Vec<SourceView>,
    /// The person could not be fitted here: the last pose is held.
    pub held: bool,
    pub runs: ModelRuns,
    pub models: Duration,
    /// Of `models`, the frame's crop and resize.
    pub prepare: Duration,
    pub fit: Duration,
}

/// The fit's half of tracking: a solver per setting, from the clip's start.
pub struct Fitter {
    solvers: Vec<Solver>,
    embedding: Option<FaceEmbedding>,
    crop: Option<Crop>,
    fps: f32,
}

impl Fitter {
    /// Fitters continuing from `start`, one per entry of `filtered` (one, filtered, for a
    /// tracking file; raw and filtered side by side to measure the filters), for a `fps` video;
    /// with the start's own frame.
    pub fn start(
        body: &BodyModel,
        start: &ClipStart,
        filtered: &[bool],
        fps: f32,
    ) -> (Self, FrameTrack) {
        let solvers = filtered
            .iter()
            .map(|&f| {
                let mut solver = Solver::new(start.state.clone(), f);
                solver.prime(&start.detections, start.time_s);
                solver
            })
            .collect();
        let fitter = Self {
            solvers,
            embedding: start.embedding.clone(),
            crop: start.view.crop,
            fps,
        };
        let track = FrameTrack {
            frames: vec![start.view.to_frame(body); filtered.len()],
            views: vec![start.view.clone(); filtered.len()],
            held: false,
            runs: ModelRuns {
                person_search: true,
                face_search: true,
                hand_searches: 2,
                ..ModelRuns::default()
            },
            models: start.models,
            prepare: Duration::ZERO,
            fit: start.fit,
        };
        (fitter, track)
    }

    /// Fits a frame the models saw.
    pub fn fit(&mut self, body: &BodyModel, seen: &SeenFrame) -> FrameTrack {
        let started = Instant::now();
        let (mut frames, mut views, mut held) = (Vec::new(), Vec::new(), false);
        for solver in &mut self.solvers {
            let solved = solver.solve(
                body,
                self.embedding.as_ref(),
                &seen.detections,
                SOURCE_SIZE,
                seen.time_s,
                f64::from(self.fps),
            );
            held |= solved.is_none();
            let view = SourceView {
                pose: solver.output().pose.clone(),
                camera: solver.output().camera(SOURCE_SIZE),
                crop: self.crop,
            };
            frames.push(view.to_frame(body));
            views.push(view);
        }
        FrameTrack {
            frames,
            views,
            held,
            runs: seen.runs,
            models: seen.models,
            prepare: seen.prepare,
            fit: started.elapsed(),
        }
    }
}

/// Both halves in one, frame after frame on one thread (the viewer's live driving, tests).
pub struct Tracker {
    seer: Seer,
    fitter: Option<Fitter>,
    header: Option<Tracking>,
    filtered: Vec<bool>,
    fps: f32,
}

impl Tracker {
    pub fn new(name: &str, fps: f32, filtered: &[bool]) -> Self {
        Self {
            seer: Seer::new(name, fps),
            fitter: None,
            header: None,
            filtered: filtered.to_vec(),
            fps,
        }
    }

    /// The tracking file's header once the clip has started.
    pub fn header(&self) -> Option<&Tracking> {
        self.header.as_ref()
    }

    /// Tracks `frame`: `Ok(Err(why))` while no person has been found.
    pub fn track(
        &mut self,
        body: &BodyModel,
        pipeline: &mut Pipeline,
        frame: &VideoFrame,
    ) -> Result<Result<FrameTrack, String>, TrackError> {
        Ok(match self.seer.see(body, pipeline, frame)? {
            Seen::NoPerson(why) => Err(why),
            Seen::Start(start) => {
                let (fitter, track) = Fitter::start(body, &start, &self.filtered, self.fps);
                self.header = Some(start.header);
                self.fitter = Some(fitter);
                Ok(track)
            }
            Seen::Frame(seen) => {
                let fitter = self
                    .fitter
                    .as_mut()
                    .expect("a clip sees frames once started");
                Ok(fitter.fit(body, &seen))
            }
        })
    }
}

/// What tracking a whole video gave.
#[derive(Default)]
pub struct TrackOutcome {
    /// One tracking file per solver setting.
    pub tracks: Vec<Tracking>,
    /// Frames where the person could not be fitted (the last pose held), and frames before the
    /// first person was found (given the first tracked pose).
    pub held: usize,
    pub before_start: usize,
    /// How often the detectors had to search (the person, the face, a hand).
    pub person_searches: usize,
    pub face_searches: usize,
    pub hand_searches: usize,
    /// Time per stage over the whole video (summed; they overlap, see [`track_video`]), and
    /// the wall-clock time.
    pub decode: Duration,
    pub models: Duration,
    pub fit: Duration,
    pub wall: Duration,
    /// Of `models`: the frames' crop and resize, then each model ([`MODEL_PARTS`]).
    pub prepare: Duration,
    pub parts: [Duration; 4],
}

/// Frames seen ahead of the fit at most (each holds the models' points only).
const SEEN_AHEAD: usize = 4;

/// Tracks every frame of `source` with a solver per entry of `filtered`. The frames are decoded
/// and seen by the models on one thread while the fit runs on another; `progress` hears the
/// frames done and the total (when known) and cancels by answering `false`.
pub fn track_video(
    source: &mut (dyn FrameSource + Send),
    body: &BodyModel,
    pipeline: &mut Pipeline,
    filtered: &[bool],
    progress: &mut dyn FnMut(usize, Option<usize>) -> bool,
) -> Result<TrackOutcome, TrackError> {
    let info = source.info().clone();
    let started = Instant::now();
    let (send, receive) =
        std::sync::mpsc::sync_channel::<Result<(Seen, Duration), TrackError>>(SEEN_AHEAD);
    let mut outcome = TrackOutcome::default();
    std::thread::scope(|scope| {
        let name = info.name.clone();
        scope.spawn(move || {
            let mut seer = Seer::new(&name, info.fps);
            loop {
                let decoding = Instant::now();
                let Some(frame) = source.next_frame() else {
                    return;
                };
                let decoded = decoding.elapsed();
                let seen = frame
                    .map_err(TrackError::from)
                    .and_then(|frame| seer.see(body, pipeline, &frame));
                let failed = seen.is_err();
                // The fit side hung up (cancelled, or failed): stop.
                if send.send(seen.map(|s| (s, decoded))).is_err() || failed {
                    return;
                }
            }
        });
        collect(receive, body, filtered, &info, &mut outcome, progress)
    })?;
    outcome.wall = started.elapsed();
    Ok(outcome)
}

/// The fit's side of [`track_video`]: every seen frame fitted, in order.
fn collect(
    receive: std::sync::mpsc::Receiver<Result<(Seen, Duration), TrackError>>,
    body: &BodyModel,
    filtered: &[bool],
    info: &crate::video::VideoInfo,
    outcome: &mut TrackOutcome,
    progress: &mut dyn FnMut(usize, Option<usize>) -> bool,
) -> Result<(), TrackError> {
    let mut frames: Vec<Vec<Frame>> = vec![Vec::new(); filtered.len()];
    let (mut fitter, mut header, mut refusal) = (None, None::<Tracking>, String::new());
    let mut done = 0;
    while progress(done, info.frames) {
        let Ok(seen) = receive.recv() else {
            // Every frame is in.
            let Some(header) = header else {
                return Err(TrackError::NoPerson {
                    file: info.name.clone(),
                    reason: match done {
                        0 => "the video has no frames".into(),
                        _ => refusal,
                    },
                });
            };
            outcome.tracks = frames
                .into_iter()
                .map(|frames| Tracking {
                    frames,
                    ..header.clone()
                })
                .collect();
            return Ok(());
        };
        let (seen, decoded) = seen?;
        outcome.decode += decoded;
        done += 1;
        let track = match seen {
            Seen::NoPerson(why) => {
                outcome.before_start += 1;
                refusal = why;
                continue;
            }
            Seen::Start(start) => {
                let (started, track) = Fitter::start(body, &start, filtered, info.fps);
                header = Some(start.header);
                fitter = Some(started);
                track
            }
            Seen::Frame(seen) => fitter
                .as_mut()
                .expect("frames are seen once the clip started")
                .fit(body, &seen),
        };
        outcome.held += usize::from(track.held);
        outcome.person_searches += usize::from(track.runs.person_search);
        outcome.face_searches += usize::from(track.runs.face_search);
        outcome.hand_searches += track.runs.hand_searches;
        outcome.models += track.models;
        outcome.prepare += track.prepare;
        for (sum, t) in outcome.parts.iter_mut().zip(track.runs.times) {
            *sum += t;
        }
        outcome.fit += track.fit;
        for (all, frame) in frames.iter_mut().zip(track.frames) {
            // Frames before the first person take the first tracked pose.
            while all.len() < outcome.before_start {
                all.push(frame.clone());
            }
            all.push(frame);
        }
    }
    Err(TrackError::Cancelled)
}
