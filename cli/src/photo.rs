//! `guava reconstruct`, `guava fit` and `guava synth-photo`: photos in, avatars, tracking files
//! and known-answer photos out, all through the library's pipeline.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use guava::body::BodyRef;
use guava::body::{BodyModel, BodyPose, EhmModel};
use guava::guava_mode::GuavaModels;
use guava::pipeline::{
    Framing, KeypointModels, Mode, Photo, Pipeline, Tracked, fit_lines, tracking_beside,
};
use guava::tracking::SourceView;

/// Where the keypoint models come from.
#[derive(clap::Args)]
pub struct KeypointArgs {
    /// Keypoint models from this folder instead of the shipped ones (same file names and
    /// inputs and outputs as assets/models/).
    #[arg(long)]
    keypoint_models: Option<PathBuf>,
    /// EHM-Tracker's checkpoint folder (yolox_l.onnx, dw-ll_ucoco_384.onnx): its DWPose places
    /// the body and hand points; the face, irises and person mask stay MediaPipe's.
    #[arg(long)]
    dwpose: Option<PathBuf>,
}

impl KeypointArgs {
    pub fn pipeline(&self) -> Pipeline {
        Pipeline::new(KeypointModels::new(
            self.keypoint_models.clone(),
            self.dwpose.clone(),
        ))
    }
}

/// Prints each stage as it starts; never cancels.
fn print_stage(stage: guava::progress::Stage) -> bool {
    eprintln!("  {}…", stage.name());
    true
}

/// Reconstructs `image` into an avatar at `out`: the default reconstruction, or GUAVA mode with
/// `guava` = (networks folder, EHM body). `tracking` names the tracking file; without one, the
/// one beside the photo, else a fit (always a fit with `force_fit`).
pub fn reconstruct(
    image: &Path,
    tracking: Option<PathBuf>,
    force_fit: bool,
    out: &Path,
    keypoints: &KeypointArgs,
    guava: Option<(&Path, &Path)>,
) -> Result<()> {
    let tracked = match tracking {
        _ if force_fit => Tracked::Fit,
        Some(path) => Tracked::File(path),
        None => Tracked::beside(image),
    };
    let mut pipeline = keypoints.pipeline();
    let outcome = match guava {
        Some((models, ehm)) => {
            let t0 = std::time::Instant::now();
            let mut networks = GuavaModels::load_dir(guava::onnx::OnnxRuntime::load()?, models)?;
            let body = EhmModel::load(ehm)?;
            eprintln!(
                "  GUAVA models ({}) and body {:?} loaded in {:.1} s",
                networks.source,
                body.name,
                t0.elapsed().as_secs_f64()
            );
            let mode = Mode::Guava {
                body: &body,
                networks: &mut networks,
            };
            pipeline.reconstruct(mode, Photo::File(image), tracked, &mut print_stage)?
        }
        None => {
            let body = BodyModel::default_body()?;
            let mode = Mode::Default(&body);
            pipeline.reconstruct(mode, Photo::File(image), tracked, &mut print_stage)?
        }
    };
    let avatar = &outcome.avatar;
    avatar.save(out)?;
    println!(
        "{}: {} ({} Gaussians, {} channels) → {}",
        image.display(),
        avatar.kind.label(),
        avatar.composition(),
        avatar.channels,
        out.display()
    );
    for line in outcome.report.lines() {
        println!("  {line}");
    }
    Ok(())
}

/// Fits the default body (or an EHM body) to a photo's keypoints and writes the result as a
/// tracking file; `overlay` also writes the photo with the points.
pub fn fit(
    image: &Path,
    out: &Path,
    overlay: Option<&Path>,
    keypoints: &KeypointArgs,
    ehm: Option<&Path>,
) -> Result<()> {
    let mut pipeline = keypoints.pipeline();
    let (ehm_body, template);
    // Framed as the reconstruction of that body frames it (GUAVA mode: EHM-Tracker's crop).
    let (body, framing) = match ehm {
        Some(path) => {
            ehm_body = EhmModel::load(path)?;
            (BodyRef::Ehm(&ehm_body), Framing::AroundPerson)
        }
        None => {
            template = BodyModel::default_body()?;
            (BodyRef::Template(&template), Framing::KeepCentred)
        }
    };
    let source = pipeline.source(body, Photo::File(image), Tracked::Fit, framing, &mut |_| {
        true
    })?;
    let report = &source.report;
    let fit = report.fit.as_ref().context("the fit did not run")?;
    let name = image.file_name().unwrap_or_default().to_string_lossy();
    let face = if fit.face.is_some() {
        " and face_landmark face mesh"
    } else {
        ""
    };
    let points = report.body_points.unwrap_or("no");
    let fitted =
        |body: &str| format!("fitted by guava fit to {name}: {points} keypoints{face}, {body}");
    let tracking = match body {
        BodyRef::Ehm(b) => source.view.to_tracking(b, &fitted(&b.name)),
        BodyRef::Template(b) => source.view.to_tracking(b, &fitted("default body")),
    };
    tracking.save(out)?;
    let framed = match source.view.crop {
        Some(c) => format!(", framed {}² at ({}, {})", c.side, c.left, c.top),
        None => String::new(),
    };
    let presence = source
        .photo
        .detections
        .as_ref()
        .map_or(f32::NAN, |d| d.pose.presence);
    println!(
        "{}: person presence {presence:.2}{framed} → {}",
        image.display(),
        out.display()
    );
    for line in fit_lines(fit) {
        println!("  {line}");
    }
    for (stage, d) in &report.timings {
        println!("  {:32} {:8.1} ms", stage.name(), d.as_secs_f64() * 1e3);
    }
    if let Some(path) = overlay {
        write_fit_overlay(&source.photo.image, fit, path)?;
        println!("  overlay → {}", path.display());
    }
    Ok(())
}

/// The photo at twice its size with each point found (green) and where the fitted body puts it
/// (red): body keypoints as rings, face-mesh, hand and iris points as dots.
fn write_fit_overlay(
    source: &guava::photo::SourceImage,
    report: &guava::fit::FitReport,
    path: &Path,
) -> Result<()> {
    const SCALE: f32 = 2.0;
    let side = source.size * SCALE as u32;
    let mut canvas = image::RgbImage::from_fn(side, side, |x, y| {
        let i = (y / SCALE as u32 * source.size + x / SCALE as u32) as usize;
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0) as u8;
        image::Rgb([0, 1, 2].map(|c| q(source.rgb[3 * i + c])))
    });
    let mut dot = |p: glam::Vec2, radius: f32, colour: [u8; 3], ring: bool| {
        let c = p * SCALE;
        let r = radius.ceil() as i32 + 1;
        for dy in -r..=r {
            for dx in -r..=r {
                let d = ((dx * dx + dy * dy) as f32).sqrt();
                let hit = if ring {
                    (d - radius).abs() < 0.8
                } else {
                    d <= radius
                };
                let (x, y) = (c.x as i32 + dx, c.y as i32 + dy);
                if hit && x >= 0 && y >= 0 && (x as u32) < side && (y as u32) < side {
                    canvas.put_pixel(x as u32, y as u32, image::Rgb(colour));
                }
            }
        }
    };
    let (green, red) = ([60, 230, 60], [240, 40, 40]);
    for (&seen, &fitted) in report.observed.iter().zip(&report.fitted) {
        dot(seen, 4.0, green, true);
        dot(fitted, 2.5, red, false);
    }
    let face = report
        .face
        .iter()
        .flat_map(|f| f.observed.iter().zip(&f.fitted));
    let hands = report
        .hands
        .iter()
        .flat_map(|h| h.observed.iter().zip(&h.fitted));
    let irises = report
        .gaze
        .iter()
        .flat_map(|g| g.observed.iter().zip(&g.fitted));
    for (&seen, &fitted) in face.chain(hands).chain(irises) {
        dot(seen, 1.5, green, false);
        dot(fitted, 1.0, red, false);
    }
    guava::render::save_png(&canvas, path)
}

/// What `guava eval` compares the avatar with.
pub enum Target {
    /// The photo it was made from (seen from its source view).
    Photo(PathBuf),
    /// A tracked video's frames, in name order (self-reenactment), every `every`-th compared.
    Frames { dir: PathBuf, every: usize },
    /// A video (self-reenactment): the avatar made from `reference_frame` unless given.
    Video {
        video: PathBuf,
        reference_frame: usize,
        every: usize,
    },
}

/// What `guava eval` writes and measures besides the scores.
pub struct Scoring<'a> {
    /// Where photo | render | difference go.
    pub out: Option<&'a Path>,
    /// An LPIPS model.
    pub lpips: Option<&'a Path>,
    /// Score the avatar's refiner's output instead of the splat pass's (GUAVA mode's from
    /// `guava_models`).
    pub refine: bool,
    pub guava_models: Option<&'a Path>,
}

/// Compares an avatar, re-rendered from its photo's view (or a video's tracked views), with the
/// photo (or the frames); prints the metrics, and with `out` writes photo | render | difference.
pub fn eval(
    avatar: Option<&Path>,
    target: &Target,
    tracking: Option<&Path>,
    ehm: Option<&Path>,
    scoring: &Scoring,
    keypoints: &KeypointArgs,
) -> Result<()> {
    let avatar_file = match avatar {
        Some(path) => {
            Some(guava::avatar::Avatar::load(path).with_context(|| path.display().to_string())?)
        }
        None => None,
    };
    let mut lpips = match scoring.lpips {
        Some(path) => Some(guava::eval::lpips::Lpips::load(
            guava::onnx::OnnxRuntime::load()?,
            path,
        )?),
        None => None,
    };
    let mut run = Eval {
        target,
        tracking,
        out: scoring.out,
        lpips: &mut lpips,
        refine: scoring.refine.then_some(scoring.guava_models),
        refiner: None,
        pipeline: keypoints.pipeline(),
        renderer: guava::render::HeadlessRenderer::new(guava::gpu::GpuContext::headless()?),
    };
    match (ehm, avatar_file) {
        (Some(path), Some(avatar)) => {
            let mut body = EhmModel::load(path)?;
            avatar.apply_ehm_identity(&mut body);
            run.on(avatar, &body)
        }
        (Some(_), None) => {
            anyhow::bail!("a GUAVA-mode avatar is made by guava reconstruct: give it with --avatar")
        }
        (None, Some(avatar)) => run.on(avatar, &BodyModel::default_body()?),
        (None, None) => run.video_avatar(),
    }
}

/// One `guava eval` run: what it compares with and how.
struct Eval<'a> {
    target: &'a Target,
    tracking: Option<&'a Path>,
    out: Option<&'a Path>,
    lpips: &'a mut Option<guava::eval::lpips::Lpips>,
    /// Whether to refine, and GUAVA's networks folder for a GUAVA-mode avatar's refiner.
    refine: Option<Option<&'a Path>>,
    /// The avatar's refiner, loaded once its kind is known.
    refiner: Option<guava::refine::Refiner>,
    pipeline: guava::pipeline::Pipeline,
    renderer: guava::render::HeadlessRenderer,
}

impl Eval<'_> {
    fn on(
        &mut self,
        avatar: guava::avatar::Avatar,
        body: &impl guava::body::Posable,
    ) -> Result<()> {
        avatar.check_body(body).map_err(anyhow::Error::msg)?;
        if let Some(networks) = self.refine {
            let path =
                guava::refine::refiner_for(avatar.kind, networks).map_err(anyhow::Error::msg)?;
            let refiner = guava::refine::Refiner::load_on(
                guava::refine::RefinerOn::Auto,
                &self.renderer.gpu,
                &path,
            )?;
            eprintln!(
                "  scoring the refined image: {} on {}",
                refiner.description,
                refiner.engine_name()
            );
            self.refiner = Some(refiner);
        }
        let image = match self.target {
            Target::Photo(image) => image,
            Target::Frames { dir, every } => {
                let path = self
                    .tracking
                    .expect("clap requires --tracking with --frames");
                let t = guava::tracking::Tracking::load(path)?;
                let mut frames = guava::video::FrameFolder::open(dir, t.fps)?;
                return self.reenact(&avatar, body, &mut frames, &t, None, *every);
            }
            Target::Video {
                video,
                reference_frame,
                every,
            } => {
                let t = self.video_tracking(video)?;
                let mut frames = guava::video::open(video, t.fps)?;
                return self.reenact(
                    &avatar,
                    body,
                    frames.as_mut(),
                    &t,
                    Some(*reference_frame),
                    *every,
                );
            }
        };
        let view = match self.tracking {
            Some(path) => {
                let t = guava::tracking::Tracking::load(path)?;
                SourceView::from_tracking(&t, body, &path.display().to_string())?
            }
            None => avatar
                .source_view
                .clone()
                .ok_or(guava::eval::EvalError::NoSourceView)?,
        };
        let photo = self
            .pipeline
            .masked_photo(Photo::File(image), &view, &mut |_| true)?;
        let (metrics, rendered) = guava::eval::evaluate_refined(
            &mut self.renderer,
            &avatar,
            body,
            Some(&view),
            &photo,
            self.refiner.as_mut(),
        )?;
        let d = match self.lpips {
            Some(model) => guava::eval::perceptual(model, &rendered, &photo)?,
            None => f64::NAN,
        };
        println!("{metrics}{}", lpips_text(d));
        if let Some(path) = self.out {
            guava::render::save_png(&guava::eval::side_by_side(&photo, &rendered), path)?;
            println!("photo | render | difference → {}", path.display());
        }
        Ok(())
    }

    /// The video's tracking: the file given, or tracked here (filtered).
    fn video_tracking(&mut self, video: &Path) -> Result<guava::tracking::Tracking> {
        match self.tracking {
            Some(path) => Ok(guava::tracking::Tracking::load(path)?),
            None => {
                let body = BodyModel::default_body()?;
                let fps = 30.0;
                crate::track::track_file(video, fps, &body, &mut self.pipeline)
            }
        }
    }

    /// `--video` without `--avatar`: the default reconstruction of the reference frame, seen
    /// through its tracked view, then self-reenactment.
    fn video_avatar(&mut self) -> Result<()> {
        let Target::Video {
            video,
            reference_frame,
            ..
        } = self.target
        else {
            anyhow::bail!("give --avatar");
        };
        let body = BodyModel::default_body()?;
        let t = self.video_tracking(video)?;
        let mut frames = guava::video::open(video, t.fps)?;
        let frame = std::iter::from_fn(|| frames.next_frame())
            .nth(*reference_frame)
            .with_context(|| {
                format!(
                    "{}: has no frame {reference_frame} (--reference-frame)",
                    video.display()
                )
            })??;
        let file = self.tracking.map_or_else(
            || format!("{} (tracked)", video.display()),
            |p| p.display().to_string(),
        );
        let view = SourceView::at_frame(&t, &body, *reference_frame, &file)?;
        let name = format!("{} frame {reference_frame}", video.display());
        let outcome = self.pipeline.reconstruct(
            guava::pipeline::Mode::Default(&body),
            Photo::Pixels {
                name: &name,
                pixels: frame.pixels,
                has_alpha: false,
            },
            guava::pipeline::Tracked::Given(view),
            &mut |_| true,
        )?;
        eprintln!(
            "  avatar from frame {reference_frame}: {} ({} Gaussians)",
            outcome.avatar.kind.label(),
            outcome.avatar.len()
        );
        // Kept beside the compared frames, so the avatar they score can be opened and turned.
        if let Some(dir) = self.out {
            std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
            let path = dir.join("avatar.guava");
            outcome.avatar.save(&path)?;
            eprintln!("  avatar → {}", path.display());
        }
        self.on(outcome.avatar, &body)
    }

    /// Self-reenactment: every `every`-th frame of `frames` against the avatar posed and seen
    /// as that frame (its tracked pose and camera, with the avatar's identity); one line per
    /// frame, then the means (without the reference frame, which the avatar was made from).
    fn reenact(
        &mut self,
        avatar: &guava::avatar::Avatar,
        body: &impl guava::body::Posable,
        frames: &mut dyn guava::video::FrameSource,
        t: &guava::tracking::Tracking,
        reference: Option<usize>,
        every: usize,
    ) -> Result<()> {
        let name = frames.info().name.clone();
        if let Some(n) = frames.info().frames
            && n != t.frames.len()
        {
            anyhow::bail!(
                "{name}: {n} frames, but its tracking has {} (one tracked frame per frame)",
                t.frames.len()
            );
        }
        if let Some(dir) = self.out {
            std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
        }
        let file = self
            .tracking
            .map_or_else(|| format!("{name} (tracked)"), |p| p.display().to_string());
        let (mut sums, mut compared, mut written) = ([0.0f64; 6], 0usize, Vec::new());
        while let Some(frame) = frames.next_frame() {
            let frame = frame?;
            let i = frame.index;
            if !i.is_multiple_of(every) {
                continue;
            }
            let mut view = SourceView::at_frame(t, body, i, &file)?;
            avatar.apply_identity(body, &mut view.pose);
            let label = format!("{name} frame {i}");
            // A frame's alpha, where it has one (frames written with a person mask), is the mask.
            let has_alpha = frame.pixels.pixels().any(|p| p[3] < u8::MAX);
            let photo = self.pipeline.masked_photo(
                Photo::Pixels {
                    name: &label,
                    pixels: frame.pixels,
                    has_alpha,
                },
                &view,
                &mut |_| true,
            )?;
            // Where the frame's square leaves the frame (padding) nothing is compared.
            let (m, rendered) = guava::eval::evaluate_refined(
                &mut self.renderer,
                avatar,
                body,
                Some(&view),
                &photo,
                self.refiner.as_mut(),
            )
            .with_context(|| label.clone())?;
            let d = match self.lpips.as_mut() {
                Some(model) => guava::eval::perceptual(model, &rendered, &photo)
                    .with_context(|| label.clone())?,
                None => f64::NAN,
            };
            let is_reference = reference == Some(i);
            println!(
                "frame {i}: {m}{}{}",
                lpips_text(d),
                if is_reference {
                    " (the reference frame)"
                } else {
                    ""
                }
            );
            if let Some(dir) = self.out {
                let path = guava::render::sequence::frame_path(dir, written.len());
                guava::render::save_png(&guava::eval::side_by_side(&photo, &rendered), &path)?;
                written.push(path);
            }
            if !is_reference {
                for (s, v) in sums
                    .iter_mut()
                    .zip([m.iou, m.psnr, m.ssim, m.l1, m.outline, d])
                {
                    *s += v;
                }
                compared += 1;
            }
        }
        if frames.info().frames.is_none() && compared == 0 {
            anyhow::bail!("{name}: no frame to compare");
        }
        let n = compared.max(1) as f64;
        println!(
            "mean over {compared} frames{}: iou={:.4} psnr={:.2} ssim={:.4} l1={:.4} outline={:.2}{}",
            if reference.is_some() {
                " (the reference frame left out)"
            } else {
                ""
            },
            sums[0] / n,
            sums[1] / n,
            sums[2] / n,
            sums[3] / n,
            sums[4] / n,
            lpips_text(sums[5] / n)
        );
        if let (Some(dir), false) = (self.out, written.is_empty()) {
            let mp4 = dir.join("compare.mp4");
            let fps = (t.fps / every as f32).max(1.0);
            guava::render::sequence::write_mp4(&written, fps, &mp4)?;
            println!(
                "photo | render | difference: {} frames and {}",
                written.len(),
                mp4.display()
            );
        }
        Ok(())
    }
}

/// ` lpips=…` where it was measured (not NaN), else nothing.
fn lpips_text(d: f64) -> String {
    match d.is_nan() {
        true => String::new(),
        false => format!(" lpips={d:.4}"),
    }
}

/// The synthetic subjects `guava synth-photo` draws.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum SubjectName {
    Bare,
    Clothed,
    Haired,
    ClothedAndHaired,
}

/// Writes a synthetic photo of the default body (bare with a colour pattern, or a subject with
/// clothing or hair) and its exact tracking beside it.
pub fn synth_photo(out: &Path, yaw: f32, subject: SubjectName) -> Result<()> {
    let body = BodyModel::default_body()?;
    let view = SourceView {
        pose: BodyPose::rest(&body),
        camera: guava::synthetic::upper_body_camera(&body, yaw.to_radians()),
        crop: None,
    };
    save_image(&synth_image(&body, subject, &view)?, out)?;
    let tracking_path = tracking_beside(out);
    let name = out.file_name().unwrap_or_default().to_string_lossy();
    view.to_tracking(
        &body,
        &format!("synthetic photo {name} (guava synth-photo, {subject:?})"),
    )
    .save(&tracking_path)?;
    println!(
        "wrote {} (synthetic: the default body, {subject:?}, yaw {yaw}°) and its tracking {}",
        out.display(),
        tracking_path.display()
    );
    Ok(())
}

/// A synthetic video: the subject posed along `motion` at `fps`, seen by the upper-body camera
/// at `yaw`, as `frame_00000.png`, … in `dir` with `tracking.json` (every frame's pose and
/// camera): a known answer for self-reenactment (`guava eval --frames`).
pub fn synth_sequence(
    dir: &Path,
    yaw: f32,
    subject: SubjectName,
    motion: &Path,
    fps: f32,
) -> Result<()> {
    let body = BodyModel::default_body()?;
    let t = guava::tracking::import::open_motion(motion)?.tracking;
    let retarget = guava::tracking::Retarget::new(&t, &body);
    let camera = guava::synthetic::upper_body_camera(&body, yaw.to_radians());
    std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    let source = format!(
        "synthetic video (guava synth-photo --sequence, {subject:?}, {} at {fps} fps)",
        motion.display()
    );
    let mut tracking: Option<guava::tracking::Tracking> = None;
    let times = guava::render::sequence::frame_times(t.duration(), fps);
    for (i, &time) in times.iter().enumerate() {
        let mut pose = BodyPose::rest(&body);
        retarget.sample(&t, time, &mut pose);
        let view = SourceView {
            pose,
            camera,
            crop: None,
        };
        save_image(
            &synth_image(&body, subject, &view)?,
            &guava::render::sequence::frame_path(dir, i),
        )?;
        let frame = view.to_tracking(&body, &source);
        match &mut tracking {
            Some(all) => all.frames.extend(frame.frames),
            None => tracking = Some(frame),
        }
        eprint!("\rframe {}/{}", i + 1, times.len());
    }
    eprintln!();
    let mut tracking = tracking.ok_or_else(|| anyhow::anyhow!("the motion has no frame"))?;
    tracking.fps = fps;
    let path = dir.join("tracking.json");
    tracking.save(&path)?;
    println!(
        "wrote {} frames of {} and their tracking {}",
        times.len(),
        dir.display(),
        path.display()
    );
    Ok(())
}

fn synth_image(
    body: &BodyModel,
    subject: SubjectName,
    view: &SourceView,
) -> Result<image::RgbaImage> {
    use guava::synthetic::{self, Subject};
    Ok(match subject {
        SubjectName::Bare => {
            synthetic::photo(body, &view.pose, &view.camera, synthetic::banded_texture)?
        }
        other => {
            let subject = match other {
                SubjectName::Clothed => Subject::clothed(body),
                SubjectName::Haired => Subject::haired(body),
                _ => Subject::clothed_and_haired(body),
            };
            subject.photo(&view.pose, &view.camera, synthetic::subject_texture)?
        }
    })
}

fn save_image(image: &image::RgbaImage, out: &Path) -> Result<()> {
    guava::atomic_file::write_atomic(out, |w| {
        image
            .write_to(w, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
    .with_context(|| format!("writing {}", out.display()))
}
