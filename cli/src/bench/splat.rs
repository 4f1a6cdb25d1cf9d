//! `guava bench splat`: times the splatting pass on seeded random clouds (centres in a unit
//! ball, seen from 3 units at a 50° vertical field of view, the scene of the web-splat comparison)
//! and prints one table row per configuration with per-stage medians.
//!
//! Stage times come from GPU timestamps on a GPU that has them; otherwise (and on CPU adapters)
//! each stage is submitted on its own and timed on the CPU from submit to completion (that adds
//! one submission's overhead per stage, so the stage sum exceeds the whole-frame time). The frame
//! time is always the CPU wall time of one whole submitted frame, median over `--frames`.

use glam::Vec3;
use guava::camera::{Camera, orbit};
use guava::gaussians::synthetic::BallCloud;
use guava::gpu::GpuContext;
use guava::render::StageTimer;
use guava::render::wait;
use guava::render::{FeatureStorage, HeadlessRenderer, Stage};

use super::median;
use std::time::Instant;

#[derive(clap::Args, Clone, Debug)]
pub struct SplatBenchArgs {
    /// Cloud sizes.
    #[arg(long, value_delimiter = ',', default_values_t = [10_000usize, 150_000, 1_000_000])]
    pub counts: Vec<usize>,
    /// Square image sides in pixels.
    #[arg(long, value_delimiter = ',', default_values_t = [512u32, 1024])]
    pub sizes: Vec<u32>,
    /// Feature channel counts.
    #[arg(long, value_delimiter = ',', default_values_t = [3u32, 32])]
    pub channels: Vec<u32>,
    /// Timed frames per configuration (after two warm-up frames).
    #[arg(long, default_value_t = 7)]
    pub frames: usize,
    /// Also write each configuration's cloud as PLY here (to time a peer renderer on the same data).
    #[arg(long)]
    pub write_ply: Option<std::path::PathBuf>,
    /// Store the features as f16 (half their memory and bandwidth).
    #[arg(long)]
    pub f16: bool,
}

pub fn splat(args: &SplatBenchArgs) -> anyhow::Result<()> {
    let storage = match args.f16 {
        true => FeatureStorage::F16,
        false => FeatureStorage::F32,
    };
    let mut renderer = HeadlessRenderer::with_storage(GpuContext::headless()?, storage);
    // A CPU adapter's timestamps misplace the work (on lavapipe the preprocess of 150k Gaussians
    // read 0.05 ms, its time landing in later stages), so there each stage is timed on its own.
    let timer = match renderer.gpu.adapter.get_info().device_type {
        wgpu::DeviceType::Cpu => None,
        _ => StageTimer::new(&renderer.gpu.device, &renderer.gpu.queue),
    };
    println!(
        "adapter: {}; features stored as {storage:?}",
        renderer.gpu.adapter_label()
    );
    println!(
        "stage times: {}; frame: CPU wall time of a whole submitted frame; medians of {} frames",
        if timer.is_some() {
            "GPU timestamps"
        } else {
            "CPU timers, one submission per stage"
        },
        args.frames
    );
    let stage_names: Vec<_> = Stage::ALL
        .iter()
        .map(|s| format!("{:>11}", s.name()))
        .collect();
    println!(
        "{:>9} {:>6} {:>3} {:>9} {:>10} {} {:>9} {:>9}",
        "gaussians",
        "size",
        "C",
        "visible",
        "pairs",
        stage_names.join(" "),
        "frame ms",
        "B/gauss"
    );
    for &count in &args.counts {
        for &channels in &args.channels {
            let cloud = BallCloud::new(count, channels as usize, 7).generate();
            if let Some(dir) = &args.write_ply {
                std::fs::create_dir_all(dir)?;
                guava::gaussians::ply::write(
                    &dir.join(format!("ball_{count}_c{channels}.ply")),
                    &cloud,
                )?;
            }
            let (device, queue) = (&renderer.gpu.device, &renderer.gpu.queue);
            renderer.splatter.upload(device, queue, &cloud)?;
            for &size in &args.sizes {
                let fov = 50f32.to_radians();
                let camera = Camera::from_fov_y(orbit(Vec3::ZERO, 3.0, 0.0, 0.0), size, size, fov);
                let background = vec![0.0; channels as usize];
                let stats = renderer.draw(&camera, &background);
                renderer.draw(&camera, &background);
                let (device, queue) = (&renderer.gpu.device, &renderer.gpu.queue);
                let splatter = &renderer.splatter;
                let mut frame_ms = Vec::new();
                let mut stage_ms = vec![Vec::new(); Stage::ALL.len()];
                for _ in 0..args.frames {
                    let mut encoder = device.create_command_encoder(&Default::default());
                    splatter.encode(&mut encoder, timer.as_ref());
                    if let Some(t) = &timer {
                        t.resolve(&mut encoder);
                    }
                    let start = Instant::now();
                    queue.submit([encoder.finish()]);
                    wait(device);
                    frame_ms.push(start.elapsed().as_secs_f64() * 1e3);
                    match &timer {
                        Some(t) => {
                            for (k, ms) in t.read_ms(device, queue).into_iter().enumerate() {
                                stage_ms[k].push(ms);
                            }
                        }
                        None => {
                            for (k, stage) in Stage::ALL.iter().enumerate() {
                                let mut encoder =
                                    device.create_command_encoder(&Default::default());
                                splatter.encode_stage(&mut encoder, *stage, None);
                                let start = Instant::now();
                                queue.submit([encoder.finish()]);
                                wait(device);
                                stage_ms[k].push(start.elapsed().as_secs_f64() * 1e3);
                            }
                        }
                    }
                }
                let mem = splatter.memory();
                let stages: Vec<_> = stage_ms
                    .into_iter()
                    .map(|v| format!("{:>11.2}", median(v)))
                    .collect();
                println!(
                    "{:>9} {:>6} {:>3} {:>9} {:>10} {} {:>9.2} {:>9}",
                    count,
                    format!("{size}²"),
                    channels,
                    stats.visible,
                    stats.tile_pairs,
                    stages.join(" "),
                    median(frame_ms),
                    mem.bytes_per_gaussian
                        + mem.bytes_per_pair * mem.pair_capacity / count.max(1) as u64
                );
            }
        }
    }
    Ok(())
}
