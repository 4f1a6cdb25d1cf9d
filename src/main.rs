//! `guava`: the headless CLI. `guava info` reports the GPU and ONNX Runtime; `guava render` draws a
//! splat file or an avatar to PNG; `guava motion` reads and converts motion files; `guava
//! synth-photo` and `guava reconstruct` make avatars; `guava bench` times stages.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use guava::camera::Camera;
use guava::gpu::GpuContext;
use guava::render::HeadlessRenderer;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    name = "guava",
    version,
    about = "GUAVA Gaussian avatars: headless tools"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print the GPU adapter, its limits, and whether ONNX Runtime loads.
    Info,
    /// Render a 3DGS .ply file or an avatar to a PNG, framed by an orbit camera.
    Render {
        /// A splat file: 3DGS PLY (standard or PlayCanvas's compressed layout) or antimatter15's .splat
        #[arg(long, required_unless_present = "avatar", conflicts_with = "avatar")]
        ply: Option<PathBuf>,
        /// An avatar file (.guava), posed on the default body.
        #[arg(long)]
        avatar: Option<PathBuf>,
        /// With --avatar: the EHM body (tools/convert_ehm.py) a GUAVA-mode avatar is bound to;
        /// without it, avatars are posed on the default body.
        #[arg(long, requires = "avatar")]
        ehm: Option<PathBuf>,
        /// With --avatar: pose it from this motion (tracking .json, ARKit .csv, SMPL-X .npz) at --time.
        #[arg(long, requires = "avatar")]
        motion: Option<PathBuf>,
        #[arg(long, default_value_t = 0.0, requires = "motion")]
        time: f64,
        /// With --motion: view through the motion's tracked camera (512², as GUAVA renders).
        #[arg(long, requires = "motion")]
        tracked_camera: bool,
        #[arg(long)]
        out: PathBuf,
        #[arg(long, default_value_t = 512)]
        width: u32,
        #[arg(long, default_value_t = 512)]
        height: u32,
        /// Vertical field of view in degrees.
        #[arg(long, default_value_t = 50.0)]
        fov: f32,
        /// Orbit angles in degrees around the cloud's centre.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        yaw: f32,
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        pitch: f32,
    },
    /// Read a motion (tracking .json, ARKit .csv, SMPL-X .npz), say what the default body (or an
    /// EHM model) takes of it, and optionally write it in our tracking format.
    Motion {
        file: PathBuf,
        /// Write it as a tracking .json (validated, atomically).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Report retargeting onto this EHM model (.npz) instead of the default body.
        #[arg(long)]
        ehm: Option<PathBuf>,
    },
    /// Write a synthetic photo of the default body (a smooth colour pattern on its surface, drawn
    /// from GUAVA's camera) and its exact tracking beside it (same name, .json): a known answer
    /// for reconstruction.
    SynthPhoto {
        #[arg(long)]
        out: PathBuf,
        /// Camera yaw around the body in degrees (positive: towards the body's left).
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        yaw: f32,
    },
    /// Reconstruct a photo into an avatar: the default reconstruction, or GUAVA mode with
    /// --guava-models and --ehm; the pose and camera from its tracking file, or fitted.
    Reconstruct {
        /// PNG or JPEG; its alpha channel, if any, is the person mask.
        #[arg(long)]
        image: PathBuf,
        /// The photo's tracking (frame 0's pose and camera); default: beside the image (.json),
        /// and without one, a fit to the pose model's keypoints.
        #[arg(long, conflicts_with = "fit")]
        tracking: Option<PathBuf>,
        /// Fit the pose and camera to the photo even if a tracking file is beside it.
        #[arg(long)]
        fit: bool,
        /// The avatar file to write (.guava).
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        keypoints: KeypointArgs,
        /// GUAVA mode: the folder of GUAVA's networks as exported by
        /// tools/export_guava_onnx.py (needs --ehm; without a tracking file of that body, EHM is
        /// fitted to the keypoints).
        #[arg(long, requires = "ehm")]
        guava_models: Option<PathBuf>,
        /// GUAVA mode: the EHM body (tools/convert_ehm.py).
        #[arg(long, requires = "guava_models")]
        ehm: Option<PathBuf>,
    },
    /// Fit the default body's (or, with --ehm, GUAVA's body's) pose, shape, expression and fingers
    /// and GUAVA's camera to a photo's body, face and hand keypoints (MediaPipe's models through
    /// ONNX Runtime) and write them as a tracking file.
    Fit {
        #[arg(long)]
        image: PathBuf,
        #[arg(long)]
        out: PathBuf,
        /// Also write the photo (the square it was fitted in, at 512²) with the points found (green) and where the
        /// fitted body puts them (red), twice the size, as PNG.
        #[arg(long)]
        overlay: Option<PathBuf>,
        #[command(flatten)]
        keypoints: KeypointArgs,
        /// Fit this EHM body (tools/convert_ehm.py; GUAVA mode's) instead of the default body.
        #[arg(long)]
        ehm: Option<PathBuf>,
    },
    /// Benchmarks (print a table).
    Bench {
        #[command(subcommand)]
        which: Bench,
    },
}

/// Where the keypoint models come from.
#[derive(clap::Args)]
struct KeypointArgs {
    /// Keypoint models from this folder instead of the shipped ones (same file names and
    /// inputs and outputs as assets/models/).
    #[arg(long)]
    keypoint_models: Option<PathBuf>,
    /// EHM-Tracker's checkpoint folder (yolox_l.onnx, dw-ll_ucoco_384.onnx): its DWPose places
    /// the body and hand points; the face, irises and person mask stay MediaPipe's.
    #[arg(long)]
    dwpose: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Bench {
    /// The splatting pass: per-stage times over cloud sizes, resolutions and channel counts.
    Splat(guava::bench::SplatBenchArgs),
    /// Posing the default body on one CPU core: skinning, transforms and triangle frames.
    Body(guava::bench::BodyBenchArgs),
    /// Default reconstruction of a synthetic photo, per stage, and animating the avatar.
    Reconstruct(guava::bench::ReconstructBenchArgs),
    /// GUAVA mode's reconstruction with a folder of exported models, per stage.
    Guava(guava::bench::GuavaBenchArgs),
}

fn main() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    if let Err(e) = run(Cli::parse()) {
        eprintln!("guava: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info => info(),
        Command::Render {
            ply,
            avatar,
            ehm,
            motion,
            time,
            tracked_camera,
            out,
            width,
            height,
            fov,
            yaw,
            pitch,
        } => {
            // Avatars stand on a y-up body; splat files use GUAVA's y-down axes.
            let is_avatar = avatar.is_some();
            let (cloud, name, tracked) = match (ply, avatar) {
                (Some(ply), _) => {
                    let cloud = guava::gaussians::read_file(&ply)?;
                    (cloud, ply.display().to_string(), None)
                }
                (None, Some(avatar)) => {
                    let avatar_file = guava::avatar::Avatar::load(&avatar)?;
                    let (cloud, camera) = match ehm {
                        Some(ehm) => {
                            let mut body = guava::body::EhmModel::load(&ehm)?;
                            avatar_file.apply_ehm_identity(&mut body);
                            posed_avatar(&avatar_file, &body, motion.as_deref(), time)
                        }
                        None => posed_avatar(
                            &avatar_file,
                            &guava::body::BodyModel::default_body()?,
                            motion.as_deref(),
                            time,
                        ),
                    }
                    .with_context(|| avatar.display().to_string())?;
                    (
                        cloud,
                        avatar.display().to_string(),
                        camera.filter(|_| tracked_camera),
                    )
                }
                (None, None) => anyhow::bail!("give --ply or --avatar"),
            };
            if tracked_camera && tracked.is_none() {
                anyhow::bail!("--tracked-camera: the motion has no tracked camera");
            }
            let camera = match tracked {
                Some(camera) => camera,
                None => {
                    let view = guava::camera::orbit_view(
                        &cloud,
                        fov.to_radians(),
                        yaw.to_radians(),
                        pitch.to_radians(),
                        is_avatar,
                    )
                    .with_context(|| format!("{name}: no finite Gaussian to frame"))?;
                    Camera::from_fov_y(view, width, height, fov.to_radians())
                }
            };
            let mut renderer = HeadlessRenderer::new(GpuContext::headless()?);
            let background = vec![0.0; cloud.channels];
            let (image, stats) = renderer.render(&cloud, &camera, &background)?;
            guava::render::save_png(&image.to_rgb8(), &out)?;
            println!(
                "{name}: {} Gaussians, {} drawn, {} culled ({} tile pairs) → {} [{}]",
                stats.input,
                stats.visible,
                stats.culled(),
                stats.tile_pairs,
                out.display(),
                renderer.gpu.adapter_label()
            );
            Ok(())
        }
        Command::SynthPhoto { out, yaw } => synth_photo(&out, yaw),
        Command::Reconstruct {
            image,
            tracking,
            fit: force_fit,
            out,
            keypoints,
            guava_models,
            ehm,
        } => {
            use guava::reconstruct::{Tracked, tracking_beside};
            let beside = tracking_beside(&image);
            let tracked = match tracking.as_deref() {
                _ if force_fit => Tracked::Fit,
                Some(path) => Tracked::File(path),
                None if beside.is_file() => Tracked::File(&beside),
                None => Tracked::Fit,
            };
            match (guava_models, ehm) {
                (Some(models), Some(ehm)) => {
                    reconstruct_guava(&image, tracked, &models, &ehm, &out, &keypoints)
                }
                _ => reconstruct(&image, tracked, &out, &keypoints),
            }
        }
        Command::Fit {
            image,
            out,
            overlay,
            keypoints,
            ehm,
        } => fit(&image, &out, overlay.as_deref(), &keypoints, ehm.as_deref()),
        Command::Motion { file, out, ehm } => motion(&file, out.as_deref(), ehm.as_deref()),
        Command::Bench { which } => match which {
            Bench::Splat(args) => guava::bench::splat(&args),
            Bench::Body(args) => guava::bench::body(&args),
            Bench::Reconstruct(args) => guava::bench::reconstruct(&args),
            Bench::Guava(args) => guava::bench::guava(&args),
        },
    }
}

/// An avatar posed on its body: at rest, or by `motion` at `time` (then also the motion's tracked
/// camera at that time, if it has one).
fn posed_avatar(
    avatar: &guava::avatar::Avatar,
    body: &impl guava::body::Posable,
    motion: Option<&Path>,
    time: f64,
) -> Result<(guava::gaussians::GaussianCloud, Option<Camera>)> {
    use guava::body::{BodyPose, PosedBody};
    avatar.check_body(body).map_err(anyhow::Error::msg)?;
    let mut pose = BodyPose::rest(body);
    let mut camera = None;
    if let Some(motion) = motion {
        let t = guava::tracking::import::open_motion(motion)?.tracking;
        guava::tracking::Retarget::new(&t, body).sample(&t, time, &mut pose);
        camera = guava::tracking::camera_at(&t, time)
            .map(|(w2c, invtanfov)| Camera::guava(w2c, guava::reconstruct::SOURCE_SIZE, invtanfov));
    }
    avatar.apply_identity(body, &mut pose);
    let mut posed = PosedBody::default();
    body.pose(&pose, &mut posed)?;
    let mut cloud = guava::gaussians::GaussianCloud::new(avatar.channels);
    guava::avatar::Rig::default().animate(avatar, &posed, body.triangles(), &mut cloud)?;
    Ok((cloud, camera))
}

fn synth_photo(out: &Path, yaw: f32) -> Result<()> {
    use guava::reconstruct::{SourceView, synthetic};
    let body = guava::body::BodyModel::default_body()?;
    let view = SourceView {
        pose: guava::body::BodyPose::rest(&body),
        camera: synthetic::upper_body_camera(&body, yaw.to_radians()),
        crop: None,
    };
    let image = synthetic::photo(&body, &view.pose, &view.camera, synthetic::banded_texture)?;
    guava::atomic_file::write_atomic(out, |w| {
        image
            .write_to(w, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
    .with_context(|| format!("writing {}", out.display()))?;
    let tracking_path = guava::reconstruct::tracking_beside(out);
    let name = out.file_name().unwrap_or_default().to_string_lossy();
    view.to_tracking(
        &body,
        &format!("synthetic photo {name} (guava synth-photo)"),
    )
    .save(&tracking_path)?;
    println!(
        "wrote {} (synthetic: the default body with a colour pattern, yaw {yaw}°) and its tracking {}",
        out.display(),
        tracking_path.display()
    );
    Ok(())
}

/// The keypoint models (shipped, or from `--keypoint-models`, with EHM-Tracker's from
/// `--dwpose`) on the installed ONNX Runtime.
fn landmarkers(args: &KeypointArgs) -> Result<guava::keypoints::Landmarkers> {
    use guava::keypoints::{Landmarkers, MODELS_DIR};
    let runtime = guava::onnx::OnnxRuntime::load()?;
    let dir = args.keypoint_models.as_deref();
    let models = Landmarkers::load_dir(runtime, dir.unwrap_or(Path::new(MODELS_DIR)))?;
    Ok(match &args.dwpose {
        Some(dir) => models.with_wholebody(runtime, dir)?,
        None => models,
    })
}

/// One line on the fit, and one on its face stage.
fn print_fit(f: &guava::fit::FitReport) {
    println!(
        "  fitted to {} body keypoints: {:.1} px RMS after {} iterations",
        f.keypoints_used, f.rms_px, f.iterations
    );
    match (&f.face, &f.face_skipped) {
        (Some(face), _) => println!(
            "  face: {} face-mesh points, {:.1} px RMS (rest expression: {:.1} px); head {:.2}× the template's",
            face.points_used,
            face.rms_px,
            face.rms_before_px,
            1.0 + face.head_size.unwrap_or(0.0)
        ),
        (None, Some(why)) => println!("  face not fitted: {why}"),
        (None, None) => {}
    }
    match &f.hands {
        Some(h) => println!(
            "  hands: {} found, {} points, {:.1} px RMS (rest fingers: {:.1} px)",
            h.hands,
            h.observed.len(),
            h.rms_px,
            h.rms_before_px
        ),
        None => println!("  hands: none found"),
    }
    if let Some(g) = &f.gaze {
        let turns: Vec<String> = g
            .turn_rad
            .iter()
            .map(|t| format!("{:.2}", t.to_degrees()))
            .collect();
        println!(
            "  gaze: {} irises, {:.1} px RMS (eyes ahead: {:.1} px); eyes turned {}°",
            g.observed.len(),
            g.rms_px,
            g.rms_before_px,
            turns.join(" / ")
        );
    }
}

/// The keypoint models for a reconstruction: needed to fit, else optional (they mask a photo
/// without alpha; `without` says what happens without them).
fn keypoint_models_for(
    tracked: &guava::reconstruct::Tracked,
    models: &KeypointArgs,
    without: &str,
) -> Result<Option<guava::keypoints::Landmarkers>> {
    match landmarkers(models) {
        Ok(m) => Ok(Some(m)),
        Err(e) if matches!(tracked, guava::reconstruct::Tracked::Fit) => {
            Err(e.context("fitting the photo needs the keypoint models"))
        }
        Err(e) => {
            eprintln!("guava: keypoint models not available ({e:#}); {without}");
            Ok(None)
        }
    }
}

fn reconstruct(
    image: &Path,
    tracked: guava::reconstruct::Tracked,
    out: &Path,
    models: &KeypointArgs,
) -> Result<()> {
    use guava::reconstruct::{DEFAULT_UV_SIZE, MaskSource, UvMap, reconstruct_photo_file};
    let body = guava::body::BodyModel::default_body()?;
    let uv = UvMap::for_body(&body, DEFAULT_UV_SIZE);
    let without = "a photo without alpha is masked by the body's silhouette";
    let mut model = keypoint_models_for(&tracked, models, without)?;
    let (avatar, report, _) =
        reconstruct_photo_file(&body, &uv, image, tracked, model.as_mut(), &mut |stage| {
            eprintln!("  {}…", stage.name());
            true
        })?;
    save_avatar(&avatar, image, out, "")?;
    if let Some(f) = &report.fit {
        print_fit(f);
    }
    println!(
        "  texels: {} valid, {} seen by the camera, {} filled by symmetry, the rest inpainted; mask from {}",
        report.texels,
        report.observed,
        report.mirrored,
        match report.mask {
            MaskSource::Alpha => "the alpha channel",
            MaskSource::Segmentation => "the pose model's person segmentation",
            MaskSource::Silhouette => "the tracked body's silhouette",
        }
    );
    let total: f64 = report.timings.iter().map(|(_, d)| d.as_secs_f64()).sum();
    for (stage, d) in &report.timings {
        println!("  {:32} {:8.1} ms", stage.name(), d.as_secs_f64() * 1e3);
    }
    println!("  {:32} {:8.1} ms", "total", total * 1e3);
    Ok(())
}

/// Writes `avatar` to `out` and says what it is; `extra` follows the channel count.
fn save_avatar(
    avatar: &guava::avatar::Avatar,
    image: &Path,
    out: &Path,
    extra: &str,
) -> Result<()> {
    avatar.save(out)?;
    println!(
        "{}: {} ({} template + {} UV Gaussians, {} channels{extra}) → {}",
        image.display(),
        avatar.kind.label(),
        avatar.template.len(),
        avatar.uv.local.len(),
        avatar.channels,
        out.display()
    );
    Ok(())
}

/// GUAVA mode: the learned reconstruction with exported networks on an EHM body.
fn reconstruct_guava(
    image: &Path,
    tracked: guava::reconstruct::Tracked,
    models: &Path,
    ehm: &Path,
    out: &Path,
    keypoint_models: &KeypointArgs,
) -> Result<()> {
    use guava::guava_mode::{GuavaModels, reconstruct_guava_file, uv_map};
    let t0 = std::time::Instant::now();
    let mut models = GuavaModels::load_dir(guava::onnx::OnnxRuntime::load()?, models)?;
    let body = guava::body::EhmModel::load(ehm)?;
    let uv = uv_map(&body, models.dims.uv as u32);
    eprintln!(
        "  GUAVA models ({}) and body {:?} loaded in {:.1} s",
        models.source,
        body.name,
        t0.elapsed().as_secs_f64()
    );
    let without = "a photo without alpha cannot be masked";
    let mut landmarkers = keypoint_models_for(&tracked, keypoint_models, without)?;
    let (avatar, report, _) = reconstruct_guava_file(
        &mut models,
        &body,
        &uv,
        image,
        tracked,
        landmarkers.as_mut(),
        &mut |stage| {
            eprintln!("  {}…", stage.name());
            true
        },
    )?;
    let counts = format!(
        "; {} texels, {} on visible faces, {} pruned",
        report.texels, report.observed_texels, report.pruned
    );
    save_avatar(&avatar, image, out, &counts)?;
    if let Some(f) = &report.fit {
        print_fit(f);
    }
    for (stage, d) in &report.timings {
        println!("  {:32} {:8.1} ms", stage.name(), d.as_secs_f64() * 1e3);
    }
    Ok(())
}

/// Fits the default body (or an EHM body) to a photo's keypoints and writes the result as a
/// tracking file.
fn fit(
    image: &Path,
    out: &Path,
    overlay: Option<&Path>,
    models: &KeypointArgs,
    ehm: Option<&Path>,
) -> Result<()> {
    use guava::fit::{fit_detections, fit_ehm_detections};
    let mut models = landmarkers(models)?;
    let t0 = std::time::Instant::now();
    use guava::reconstruct::framing::{Framing, SourcePhoto, Square};
    // Framed as the reconstruction of that body frames it (GUAVA mode: EHM-Tracker's crop).
    let framing = match ehm {
        Some(_) => Framing::AroundPerson,
        None => Framing::KeepCentred,
    };
    let read = SourcePhoto::read(
        image,
        Square::Fitted(framing),
        Some(&mut models),
        &mut |_| true,
    )?;
    let (source, found) = (
        read.image,
        read.detections.expect("a fitted photo's keypoints"),
    );
    let t1 = std::time::Instant::now();
    let name = image.file_name().unwrap_or_default().to_string_lossy();
    let body_points = models.body_points();
    let fitted = |report: &guava::fit::FitReport, body: &str| {
        let face = if report.face.is_some() {
            " and face_landmark face mesh"
        } else {
            ""
        };
        format!("fitted by guava fit to {name}: {body_points} keypoints{face}, {body}")
    };
    let failed = |e: guava::fit::FitError| anyhow::anyhow!("{}: {e}", image.display());
    let (tracking, report) = match ehm {
        Some(path) => {
            let body = guava::body::EhmModel::load(path)?;
            let (mut view, report) =
                fit_ehm_detections(&body, &found, &mut models.face, source.size).map_err(failed)?;
            view.crop = read.crop;
            (
                view.to_tracking(&body, &fitted(&report, &body.name)),
                report,
            )
        }
        None => {
            let body = guava::body::BodyModel::default_body()?;
            let (mut view, report) =
                fit_detections(&body, &found, &mut models.face, source.size).map_err(failed)?;
            view.crop = read.crop;
            (
                view.to_tracking(&body, &fitted(&report, "default body")),
                report,
            )
        }
    };
    let t2 = std::time::Instant::now();
    tracking.save(out)?;
    let framed = match read.crop {
        Some(c) => format!(", framed {}² at ({}, {})", c.side, c.left, c.top),
        None => String::new(),
    };
    println!(
        "{}: person presence {:.2}{framed} → {}",
        image.display(),
        found.pose.presence,
        out.display()
    );
    print_fit(&report);
    println!(
        "  keypoint models {:.0} ms, fit {:.0} ms",
        (t1 - t0).as_secs_f64() * 1e3,
        (t2 - t1).as_secs_f64() * 1e3
    );
    if let Some(path) = overlay {
        write_fit_overlay(&source, &report, path)?;
        println!("  overlay → {}", path.display());
    }
    Ok(())
}

/// The photo at twice its size with each point found (green) and where the fitted body puts it
/// (red): body keypoints as rings, face-mesh, hand and iris points as dots.
fn write_fit_overlay(
    source: &guava::reconstruct::SourceImage,
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

fn motion(file: &Path, out: Option<&Path>, ehm: Option<&Path>) -> Result<()> {
    use guava::tracking::Retarget;
    let imported = guava::tracking::import::open_motion(file)?;
    let t = &imported.tracking;
    println!(
        "{}: {:?} rig, {} frames at {} fps ({:.2} s), {} joints, {} parameters, {} identity values{}",
        file.display(),
        t.body,
        t.frames.len(),
        t.fps,
        t.duration(),
        t.joints.len(),
        t.parameters.len(),
        t.identity.parameters.len(),
        if t.frames[0].camera.is_some() {
            ", cameras"
        } else {
            ""
        }
    );
    for note in &imported.notes {
        println!("  import: {note}");
    }
    let (target, report) = match ehm {
        Some(path) => {
            let mut model = guava::body::EhmModel::load(path)?;
            if let Some(identity) = &t.identity.ehm {
                model.identity = identity.to_identity();
            }
            (path.display().to_string(), Retarget::new(t, &model).report)
        }
        None => (
            "the default body".into(),
            Retarget::new(t, &guava::body::BodyModel::default_body()?).report,
        ),
    };
    println!(
        "on {target}: drives {} joints and {} parameters",
        report.joints_mapped, report.parameters_mapped
    );
    for line in report.lines() {
        println!("  {line}");
    }
    if let Some(out) = out {
        t.save(out)?;
        println!("wrote {}", out.display());
    }
    Ok(())
}

fn info() -> Result<()> {
    let gpu = GpuContext::headless()?;
    let info = gpu.adapter.get_info();
    let limits = gpu.device.limits();
    println!("adapter:   {}", gpu.adapter_label());
    println!("driver:    {} {}", info.driver, info.driver_info);
    println!("backend:   {:?}", info.backend);
    println!(
        "limits:    max storage buffer {} MiB, max buffer {} MiB, max texture {}, storage buffers/stage {}, workgroup storage {} B",
        limits.max_storage_buffer_binding_size >> 20,
        limits.max_buffer_size >> 20,
        limits.max_texture_dimension_2d,
        limits.max_storage_buffers_per_shader_stage,
        limits.max_compute_workgroup_storage_size
    );
    println!(
        "timestamps: {}",
        if gpu
            .device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
        {
            "yes"
        } else {
            "no (benchmarks use CPU timers)"
        }
    );
    println!(
        "subgroups: {}..={} lanes; rasterizer tuning: {:?}",
        info.subgroup_min_size,
        info.subgroup_max_size,
        guava::render::RasterTuning::for_device(&info, gpu.device.features())
    );
    match guava::onnx::OnnxRuntime::load() {
        Ok(rt) => println!(
            "onnxruntime: {} loaded from {}",
            rt.version,
            rt.library.display()
        ),
        Err(e) => println!("onnxruntime: not available: {e}"),
    }
    Ok(())
}
