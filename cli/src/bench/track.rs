//! `guava bench track`: tracking a video, frames a second at 480p and 720p, and how much the
//! filters take out (the change from frame to frame, raw against filtered). The real clip is
//! the shipped Pexels video (640×360) scaled to each size and encoded here by the project's own
//! H.264 encoder; a synthetic clip of the default body, whose every pose is known, says how far
//! the tracked joints are from the truth and how much of the change is jitter.

use std::path::{Path, PathBuf};

use anyhow::Result;
use guava::body::BodyModel;
use guava::pipeline::Pipeline;
use guava::track::{Jitter, TrackOutcome, joint_errors, track_video};
use guava::video::{FrameList, VideoFrame};

use super::body::cpu_name;

#[derive(clap::Args, Clone, Debug)]
pub struct TrackBenchArgs {
    /// The video to scale to each size (H.264 MP4/MOV); default: the shipped Pexels clip.
    #[arg(long)]
    video: Option<PathBuf>,
    /// Frames of it to track at each size.
    #[arg(long, default_value_t = 240, value_parser = crate::args::frame_count)]
    frames: usize,
    /// Heights to scale it to (16:9 widths), comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [480u32, 720])]
    heights: Vec<u32>,
}

pub fn track(args: &TrackBenchArgs) -> Result<()> {
    let body = BodyModel::default_body()?;
    let mut pipeline = Pipeline::default();
    pipeline.landmarkers().map_err(anyhow::Error::msg)?;
    let video = args
        .video
        .clone()
        .unwrap_or_else(|| PathBuf::from(guava::video::DEMO_VIDEO));
    let mut source = guava::video::open(&video, 30.0)?;
    let fps = source.info().fps;
    let frames: Vec<VideoFrame> = std::iter::from_fn(|| source.next_frame())
        .take(args.frames)
        .collect::<Result<_, _>>()?;
    println!(
        "CPU {} ({} cores); ONNX Runtime on the CPU; {} frames of {} at {fps:.2} fps\n",
        cpu_name(),
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        frames.len(),
        video.display()
    );
    println!(
        "{:<10} {:<9} {:>7} {:>8} {:>9} {:>7} {:>6} {:>9} {:>9} {:>9}",
        "video",
        "filters",
        "fps",
        "decode",
        "models",
        "fit",
        "held",
        "joints°",
        "face",
        "camera mm"
    );
    let dir = std::env::temp_dir().join(format!("guava-bench-track-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    for &height in &args.heights {
        let width = (height * 16 / 9) & !1;
        let path = dir.join(format!("{height}p.mp4"));
        scaled_video(&frames, width, height, fps, &path)?;
        for filtered in [false, true] {
            let mut video = guava::video::open(&path, fps)?;
            let outcome = track_video(
                video.as_mut(),
                &body,
                &mut pipeline,
                &[filtered],
                &mut |_, _| true,
            )?;
            print_row(&format!("{width}×{height}"), filtered, &outcome);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    synthetic(&body, &mut pipeline)
}

/// `frames` scaled to `width × height` and encoded to `out` by the project's encoder.
fn scaled_video(
    frames: &[VideoFrame],
    width: u32,
    height: u32,
    fps: f32,
    out: &Path,
) -> Result<()> {
    let scaled: Vec<image::RgbImage> = frames
        .iter()
        .map(|f| {
            let rgb = image::DynamicImage::ImageRgba8(f.pixels.clone()).to_rgb8();
            image::imageops::resize(&rgb, width, height, image::imageops::FilterType::Triangle)
        })
        .collect();
    guava::render::sequence::write_mp4_frames(&scaled, fps, out)
}

fn print_row(video: &str, filtered: bool, outcome: &TrackOutcome) {
    let tracking = &outcome.tracks[0];
    let n = tracking.frames.len().max(1) as f64;
    let per = |d: std::time::Duration| d.as_secs_f64() * 1e3 / n;
    let jitter = Jitter::of(tracking);
    println!(
        "{video:<10} {:<9} {:>7.1} {:>6.1}ms {:>7.1}ms {:>5.1}ms {:>6} {:>9.2} {:>9.3} {:>9.2}",
        if filtered { "on" } else { "off" },
        n / outcome.wall.as_secs_f64().max(1e-9),
        per(outcome.decode),
        per(outcome.models),
        per(outcome.fit),
        outcome.held,
        jitter.rotation_deg,
        jitter.values,
        jitter.camera_mm
    );
}

/// The synthetic clip (the demo motion's wave, 3 s at 30 fps, drawn plainly lit): tracked
/// joints against the truth, and the change per frame of raw, filtered and true motion.
fn synthetic(body: &BodyModel, pipeline: &mut Pipeline) -> Result<()> {
    let (start, count, fps) = (5.0, 90, 30.0);
    let (frames, truth) = guava::synthetic::demo_motion_clip(body, start, count, fps)?;
    let mut true_tracking = truth[0].to_tracking(body, "truth");
    true_tracking.frames = truth.iter().map(|v| v.to_frame(body)).collect();
    true_tracking.fps = fps;
    let mut source = FrameList::new("synthetic wave", fps, frames);
    let outcome = track_video(&mut source, body, pipeline, &[false, true], &mut |_, _| {
        true
    })?;
    println!(
        "\nsynthetic clip (the default body in the demo motion's wave, {count} frames at {fps} fps, \
         drawn plainly lit, 512²):"
    );
    println!(
        "{:<10} {:>14} {:>12} {:>9} {:>9}",
        "motion", "joints off px", "worst px", "joints°", "face"
    );
    let truth_jitter = Jitter::of(&true_tracking);
    println!(
        "{:<10} {:>14} {:>12} {:>9.2} {:>9.3}",
        "truth", "", "", truth_jitter.rotation_deg, truth_jitter.values
    );
    for (name, tracking) in ["raw", "filtered"].iter().zip(&outcome.tracks) {
        let errors = joint_errors(body, &truth, tracking)?;
        let jitter = Jitter::of(tracking);
        println!(
            "{name:<10} {:>14.1} {:>12.1} {:>9.2} {:>9.3}",
            errors.iter().sum::<f32>() / errors.len() as f32,
            errors.iter().fold(0.0f32, |m, &e| m.max(e)),
            jitter.rotation_deg,
            jitter.values
        );
    }
    Ok(())
}
