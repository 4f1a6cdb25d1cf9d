//! `guava track`: a video (an MP4/MOV file with H.264, or a folder of frames) into a tracking
//! file of the default body: pose, face, gaze, fingers and camera per frame.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use guava::body::BodyModel;
use guava::track::{Jitter, TrackOutcome, track_video};

#[derive(clap::Args)]
pub struct TrackArgs {
    /// The video: an MP4 or MOV file with H.264 video, or a folder of frames (PNG or JPEG,
    /// in name order).
    #[arg(long)]
    pub video: PathBuf,
    /// The tracking file to write (.json).
    #[arg(long)]
    pub out: PathBuf,
    /// Frames per second of a folder of frames (a file says its own).
    #[arg(long, default_value_t = 30.0, value_parser = crate::args::frame_rate)]
    pub fps: f32,
    /// Leave the points and the parameters unfiltered (no One Euro filters; for comparison).
    #[arg(long)]
    pub raw: bool,
    #[command(flatten)]
    pub keypoints: crate::photo::KeypointArgs,
}

pub fn run(args: &TrackArgs) -> Result<()> {
    let body = BodyModel::default_body()?;
    let mut pipeline = args.keypoints.pipeline();
    let mut source = guava::video::open(&args.video, args.fps)?;
    let info = source.info().clone();
    eprintln!(
        "{}: {}×{} at {:.2} fps{}",
        info.name,
        info.width,
        info.height,
        info.fps,
        info.frames
            .map(|n| format!(", {n} frames"))
            .unwrap_or_default()
    );
    let outcome = track_video(
        source.as_mut(),
        &body,
        &mut pipeline,
        &[!args.raw],
        &mut progress_line,
    )?;
    eprintln!();
    let tracking = &outcome.tracks[0];
    tracking.save(&args.out)?;
    let frames = tracking.frames.len();
    println!(
        "{frames} frames tracked in {:.1} s ({:.1} frames a second) → {}",
        outcome.wall.as_secs_f64(),
        frames as f64 / outcome.wall.as_secs_f64().max(1e-9),
        args.out.display()
    );
    for line in summary(&outcome, tracking.frames.len()) {
        println!("  {line}");
    }
    let jitter = Jitter::of(tracking);
    println!(
        "  change per frame ({}): joints {:.2}° summed, face units {:.3} summed, camera {:.2} mm",
        if args.raw { "raw" } else { "filtered" },
        jitter.rotation_deg,
        jitter.values,
        jitter.camera_mm
    );
    Ok(())
}

/// Prints `frame N/M` in place every 25 frames and at the end; never cancels.
pub fn progress_line(done: usize, total: Option<usize>) -> bool {
    if done.is_multiple_of(25) || Some(done) == total {
        match total {
            Some(total) => eprint!("\rframe {done}/{total}"),
            None => eprint!("\rframe {done}"),
        }
    }
    true
}

/// What a tracking run did: per-stage time per frame, searches, held frames.
pub fn summary(outcome: &TrackOutcome, frames: usize) -> Vec<String> {
    let per = |d: std::time::Duration| d.as_secs_f64() * 1e3 / frames.max(1) as f64;
    let mut lines = vec![format!(
        "per frame: decode {:.1} ms, keypoint models {:.1} ms (with decoding, on one thread), \
         fit {:.1} ms (on another)",
        per(outcome.decode),
        per(outcome.models),
        per(outcome.fit)
    )];
    let parts: Vec<String> = guava::track::MODEL_PARTS
        .iter()
        .zip(outcome.parts)
        .map(|(name, d)| format!("{name} {:.1}", per(d)))
        .collect();
    lines.push(format!(
        "  of the models' time: crop and resize {:.1} ms, {} ms",
        per(outcome.prepare),
        parts.join(", ")
    ));
    lines.push(format!(
        "searches: person {}, face {}, hands {} (otherwise each model saw the crop its last answer placed)",
        outcome.person_searches, outcome.face_searches, outcome.hand_searches
    ));
    if outcome.held > 0 {
        lines.push(format!(
            "{} frames could not be fitted and hold the last pose",
            outcome.held
        ));
    }
    if outcome.before_start > 0 {
        lines.push(format!(
            "{} frames before the first person found take the first tracked pose",
            outcome.before_start
        ));
    }
    lines
}

/// Tracks `video` with the filters on, for `guava eval --video` without `--tracking`.
pub fn track_file(
    video: &Path,
    fps: f32,
    body: &BodyModel,
    pipeline: &mut guava::pipeline::Pipeline,
) -> Result<guava::tracking::Tracking> {
    eprintln!("  tracking {}…", video.display());
    let mut source = guava::video::open(video, fps)?;
    let outcome = track_video(source.as_mut(), body, pipeline, &[true], &mut progress_line)?;
    eprintln!();
    outcome.tracks.into_iter().next().context("one setting")
}
