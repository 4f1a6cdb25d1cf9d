//! `guava`: the headless CLI. `guava info` reports the GPU and ONNX Runtime; `guava render` draws a
//! splat file or an avatar to PNG; `guava motion` reads and converts motion files; `guava
//! synth-photo` and `guava reconstruct` make avatars; `guava bench` times stages.

mod args;
mod bench;
mod photo;
mod refiner;
mod render;
mod report;
mod track;

use anyhow::Result;
use clap::{Parser, Subcommand};
use guava::gpu::GpuContext;
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
    /// Render a 3DGS .ply file or an avatar to a PNG, framed by an orbit camera; or with
    /// --sequence, a motion (or a turntable) as a PNG sequence and an animated GIF.
    Render(Box<render::RenderArgs>),
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
    /// Measure this machine: error against run time over the quality knobs (with the Pareto
    /// front), stability on extreme inputs, and what leaving work out saves; writes report.md,
    /// CSVs and an SVG plot to --out.
    Report(report::ReportArgs),
    /// Write the default refiner's training or held-out pairs (synthetic subjects reconstructed
    /// from a front photo, seen from other views and poses, beside their ground truth) as NumPy
    /// arrays for tools/train_refiner.py.
    RefinerPairs {
        #[arg(long)]
        out: PathBuf,
        #[arg(long, value_enum, default_value_t = PairSplit::Train)]
        split: PairSplit,
    },
    /// Write a synthetic photo of the default body (a smooth colour pattern on its surface, drawn
    /// from GUAVA's camera) and its exact tracking beside it (same name, .json): a known answer
    /// for reconstruction.
    SynthPhoto {
        #[arg(long, required_unless_present = "sequence")]
        out: Option<PathBuf>,
        /// Write a synthetic video instead: the subject posed along --motion, as
        /// frame_00000.png, … in this folder with tracking.json (every frame's pose and camera).
        #[arg(long, conflicts_with = "out", requires = "motion")]
        sequence: Option<PathBuf>,
        /// With --sequence: the motion the subject follows.
        #[arg(long, requires = "sequence")]
        motion: Option<PathBuf>,
        /// With --sequence: frames per second.
        #[arg(long, default_value_t = 5.0, requires = "sequence", value_parser = args::frame_rate)]
        fps: f32,
        /// Camera yaw around the body in degrees (positive: towards the body's left).
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = args::angle)]
        yaw: f32,
        /// Who is photographed: the bare body with a colour pattern (the default), or a subject
        /// in a jacket, with hair, or both (skin, cloth and hair textures).
        #[arg(long, value_enum, default_value_t = photo::SubjectName::Bare)]
        subject: photo::SubjectName,
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
        keypoints: photo::KeypointArgs,
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
        keypoints: photo::KeypointArgs,
        /// Fit this EHM body (tools/convert_ehm.py; GUAVA mode's) instead of the default body.
        #[arg(long)]
        ehm: Option<PathBuf>,
    },
    /// Write an avatar as a rigged glTF (.glb) other tools can animate: the body as a skinned
    /// mesh with its baked colour texture and expression morph targets, the avatar's splats
    /// under KHR_gaussian_splatting bound to the same skeleton, and --motion as an animation.
    Export {
        /// The avatar (default body; GUAVA-mode avatars are not exported yet).
        #[arg(long)]
        avatar: PathBuf,
        /// A motion (tracking .json, ARKit .csv, SMPL-X .npz) to write as the animation clip.
        #[arg(long)]
        motion: Option<PathBuf>,
        /// The file to write (.glb).
        #[arg(long)]
        out: PathBuf,
    },
    /// How faithful an avatar is to its photo: the avatar re-rendered from the photo's camera
    /// against the photo × person mask. Prints `iou=… psnr=… ssim=… l1=… outline=…` (silhouette
    /// IoU; PSNR, SSIM and mean absolute error of RGB over the person's box; the share of its
    /// squared error where only one silhouette is). With --video: self-reenactment.
    Eval {
        /// The avatar (with --video: made here from the reference frame when not given).
        #[arg(long, required_unless_present = "video")]
        avatar: Option<PathBuf>,
        /// The photo it was made from.
        #[arg(long, required_unless_present_any = ["frames", "video"], conflicts_with_all = ["frames", "video"])]
        image: Option<PathBuf>,
        /// Self-reenactment: a folder of video frames (PNG or JPEG, in name order) tracked by
        /// --tracking (one tracked frame, with its camera, per image); the avatar is posed and
        /// seen as each frame and compared with it, as GUAVA's paper measures.
        #[arg(long, requires = "tracking", conflicts_with = "video")]
        frames: Option<PathBuf>,
        /// Self-reenactment on a video (MP4/MOV with H.264): an avatar made from
        /// --reference-frame, driven by the tracking of every frame (--tracking, or tracked
        /// here), seen through each frame's tracked camera and compared with the frame.
        #[arg(long)]
        video: Option<PathBuf>,
        /// With --video: the frame the avatar is made from.
        #[arg(long, default_value_t = 0, requires = "video")]
        reference_frame: usize,
        /// With --video or --frames: compare every n-th frame only.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
        every: u32,
        /// The photo's tracking file, for avatars that do not carry their source view (with
        /// --frames: the video's tracking).
        #[arg(long)]
        tracking: Option<PathBuf>,
        /// The EHM body (tools/convert_ehm.py) a GUAVA-mode avatar is bound to.
        #[arg(long)]
        ehm: Option<PathBuf>,
        /// Also write the photo, the render and their difference side by side as PNG (with
        /// --video or --frames: a folder of them, one per compared frame, and compare.mp4; with
        /// --video and no --avatar, also the avatar made, as avatar.guava).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also LPIPS, with this ONNX model (tools/export_lpips_onnx.py makes LPIPS-Alex, the
        /// paper's, from the lpips package and torchvision's AlexNet weights).
        #[arg(long)]
        lpips: Option<PathBuf>,
        /// Score the image the avatar's refiner makes of the splat pass's (what the viewer shows
        /// once the view settles; GUAVA's paper scores its refiner's output): the default
        /// refiner for default-mode avatars, GUAVA's from --guava-models for GUAVA-mode ones.
        #[arg(long)]
        refine: bool,
        /// With --refine: GUAVA's networks folder, whose refiner a GUAVA-mode avatar is refined by.
        #[arg(long, requires = "refine")]
        guava_models: Option<PathBuf>,
        #[command(flatten)]
        keypoints: photo::KeypointArgs,
    },
    /// Track a video of a person (an MP4/MOV file with H.264, or a folder of frames) into a
    /// tracking file of the default body: MediaPipe's models in tracking mode, One Euro filters
    /// and the fit warm-started from frame to frame.
    Track(track::TrackArgs),
    /// Benchmarks (print a table).
    Bench {
        #[command(subcommand)]
        which: Bench,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum PairSplit {
    Train,
    HeldOut,
    /// Held-out seeds on bodies of shapes the training never saw, in unseen poses only.
    UnseenBodies,
}

#[derive(Subcommand)]
enum Bench {
    /// The splatting pass: per-stage times over cloud sizes, resolutions and channel counts.
    Splat(bench::SplatBenchArgs),
    /// Posing the default body on one CPU core: skinning, transforms and triangle frames.
    Body(bench::BodyBenchArgs),
    /// Default reconstruction of a synthetic photo, per stage, and animating the avatar.
    Reconstruct(bench::ReconstructBenchArgs),
    /// GUAVA mode's reconstruction with a folder of exported models, per stage.
    Guava(bench::GuavaBenchArgs),
    /// A viewer frame of the default avatar, pose → pixels: the GPU-resident avatar against
    /// rigging on the CPU, and an interaction replay at each resolution the viewer uses.
    Frame(bench::FrameBenchArgs),
    /// How much avatars look like their photos: synthetic subjects with known geometry from the
    /// source view, turned views and a new pose, and the real photos in the repository.
    Fidelity(bench::FidelityBenchArgs),
    /// The default refiner on held-out pairs (raw against refined, each against the truth),
    /// and what refining costs per frame.
    #[command(alias = "refine")]
    Refiner(bench::RefinerBenchArgs),
    /// Tracking a video: frames a second at 480p and 720p (the shipped clip scaled), jitter
    /// raw against filtered, and a synthetic clip's tracked joints against the truth.
    Track(bench::TrackBenchArgs),
}

fn main() {
    guava::gpu::quiet_without_wayland();
    exit_quietly_on_a_closed_pipe();
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    if let Err(e) = run(Cli::parse()) {
        eprintln!("guava: {e:#}");
        std::process::exit(1);
    }
}

/// `guava … | head` closes stdout early; `println!` then panics. End as a shell expects a
/// program killed by SIGPIPE (status 141), without a panic message; other panics as usual.
fn exit_quietly_on_a_closed_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or_default();
        if message.contains("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(141);
        }
        default(info);
    }));
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info => info(),
        Command::Render(args) => render::run(*args),
        Command::SynthPhoto {
            out,
            sequence,
            motion,
            fps,
            yaw,
            subject,
        } => match (out, sequence, motion) {
            (_, Some(dir), Some(motion)) => photo::synth_sequence(&dir, yaw, subject, &motion, fps),
            (Some(out), ..) => photo::synth_photo(&out, yaw, subject),
            _ => anyhow::bail!("give --out, or --sequence with --motion"),
        },
        Command::Report(args) => report::report(&args),
        Command::RefinerPairs { out, split } => refiner::write_pairs(
            &out,
            match split {
                PairSplit::Train => guava::eval::pairs::Split::Train,
                PairSplit::HeldOut => guava::eval::pairs::Split::HeldOut,
                PairSplit::UnseenBodies => guava::eval::pairs::Split::UnseenBodies,
            },
        ),
        Command::Reconstruct {
            image,
            tracking,
            fit: force_fit,
            out,
            keypoints,
            guava_models,
            ehm,
        } => {
            let guava = guava_models.as_deref().zip(ehm.as_deref());
            photo::reconstruct(&image, tracking, force_fit, &out, &keypoints, guava)
        }
        Command::Fit {
            image,
            out,
            overlay,
            keypoints,
            ehm,
        } => photo::fit(&image, &out, overlay.as_deref(), &keypoints, ehm.as_deref()),
        Command::Eval {
            avatar,
            image,
            frames,
            video,
            reference_frame,
            every,
            tracking,
            ehm,
            out,
            lpips,
            refine,
            guava_models,
            keypoints,
        } => {
            let every = every as usize;
            let target = match (image, frames, video) {
                (_, Some(dir), _) => photo::Target::Frames { dir, every },
                (_, _, Some(video)) => photo::Target::Video {
                    video,
                    reference_frame,
                    every,
                },
                (Some(image), None, None) => photo::Target::Photo(image),
                (None, None, None) => anyhow::bail!("give --image, --frames or --video"),
            };
            photo::eval(
                avatar.as_deref(),
                &target,
                tracking.as_deref(),
                ehm.as_deref(),
                &photo::Scoring {
                    out: out.as_deref(),
                    lpips: lpips.as_deref(),
                    refine,
                    guava_models: guava_models.as_deref(),
                },
                &keypoints,
            )
        }
        Command::Track(args) => track::run(&args),
        Command::Motion { file, out, ehm } => motion(&file, out.as_deref(), ehm.as_deref()),
        Command::Export {
            avatar,
            motion,
            out,
        } => export(&avatar, motion.as_deref(), &out),
        Command::Bench { which } => match which {
            Bench::Splat(args) => bench::splat(&args),
            Bench::Body(args) => bench::body(&args),
            Bench::Reconstruct(args) => bench::reconstruct(&args),
            Bench::Guava(args) => bench::guava(&args),
            Bench::Frame(args) => bench::frame(&args),
            Bench::Refiner(args) => bench::refiner(&args),
            Bench::Fidelity(args) => bench::fidelity(&args),
            Bench::Track(args) => bench::track(&args),
        },
    }
}

fn export(avatar: &Path, motion: Option<&Path>, out: &Path) -> Result<()> {
    let started = std::time::Instant::now();
    let loaded = guava::avatar::Avatar::load(avatar)?;
    let body = guava::body::BodyModel::default_body()?;
    let motion = match motion {
        Some(m) => Some(guava::tracking::import::open_motion(m)?.tracking),
        None => None,
    };
    let written = guava::export::export(&loaded, &body, motion.as_ref(), out, &mut |done| {
        eprint!("\r  exporting… {:3.0} %", 100.0 * done);
        true
    })
    .map_err(|e| anyhow::anyhow!("{}: {e}", avatar.display()))?;
    eprintln!();
    println!(
        "{} → {}: {} joints, {} vertices, {} morph targets, {} splats, {} animation frames; {:.1} MB in {:.2} s",
        avatar.display(),
        out.display(),
        written.joints,
        written.vertices,
        written.morph_targets,
        written.splats,
        written.frames,
        written.bytes as f64 / 1e6,
        started.elapsed().as_secs_f64()
    );
    Ok(())
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
    println!(
        "onnxruntime GPU providers asked for: {}",
        guava::onnx::requested_providers()
    );
    Ok(())
}
