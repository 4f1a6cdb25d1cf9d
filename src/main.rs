//! `guava`: the headless CLI. `guava info` reports the GPU and ONNX Runtime; `guava render` draws a
//! splat file to PNG; `guava motion` reads and converts motion files; `guava bench` times stages.

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
    /// Render a 3DGS .ply file to a PNG, framed by an orbit camera.
    Render {
        #[arg(long)]
        ply: PathBuf,
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
    /// Benchmarks (print a table).
    Bench {
        #[command(subcommand)]
        which: Bench,
    },
}

#[derive(Subcommand)]
enum Bench {
    /// The splatting pass: per-stage times over cloud sizes, resolutions and channel counts.
    Splat(guava::bench::SplatBenchArgs),
    /// Posing the default body on one CPU core: skinning, transforms and triangle frames.
    Body(guava::bench::BodyBenchArgs),
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
            out,
            width,
            height,
            fov,
            yaw,
            pitch,
        } => {
            let cloud = guava::gaussians::ply::read(&ply)?;
            let view = guava::camera::orbit_view(
                &cloud,
                fov.to_radians(),
                yaw.to_radians(),
                pitch.to_radians(),
            )
            .with_context(|| format!("{}: no finite Gaussian to frame", ply.display()))?;
            let camera = Camera::from_fov_y(view, width, height, fov.to_radians());
            let mut renderer = HeadlessRenderer::new(GpuContext::headless()?);
            let background = vec![0.0; cloud.channels];
            let (image, stats) = renderer.render(&cloud, &camera, &background)?;
            guava::render::save_png(&image.to_rgb8(), &out)?;
            println!(
                "{}: {} Gaussians, {} drawn, {} culled ({} tile pairs) → {} [{}]",
                ply.display(),
                stats.input,
                stats.visible,
                stats.culled(),
                stats.tile_pairs,
                out.display(),
                renderer.gpu.adapter_label()
            );
            Ok(())
        }
        Command::Motion { file, out, ehm } => motion(&file, out.as_deref(), ehm.as_deref()),
        Command::Bench { which } => match which {
            Bench::Splat(args) => guava::bench::splat(&args),
            Bench::Body(args) => guava::bench::body(&args),
        },
    }
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
