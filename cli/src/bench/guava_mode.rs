//! `guava bench guava`: GUAVA mode's reconstruction per stage with a folder of exported models
//! (`tools/export_guava_onnx.py`; randomly initialised full-size ones time the same as the
//! checkpoint's), on an EHM body (`tools/convert_ehm.py`; the synthetic test model has SMPL-X's
//! topology), then animating the avatar for one frame. The networks run on ONNX Runtime's
//! default CPU threads; the geometry on one thread.

use std::path::PathBuf;
use std::time::Instant;

use glam::Mat4;

use super::body::cpu_name;
use super::median;
use guava::avatar::Rig;
use guava::body::{BodyPose, EhmModel, Posable, PosedBody};
use guava::camera::Camera;
use guava::gaussians::GaussianCloud;
use guava::guava_mode::{GuavaModels, reconstruct_guava, uv_map};
use guava::onnx::OnnxRuntime;
use guava::photo::{SOURCE_SIZE, SourceImage};
use guava::tracking::SourceView;

#[derive(clap::Args, Clone, Debug)]
pub struct GuavaBenchArgs {
    /// The folder of the three GUAVA ONNX models.
    #[arg(long)]
    pub models: PathBuf,
    /// The EHM body (`.npz` from tools/convert_ehm.py).
    #[arg(long, default_value = "tests/data/ehm_synthetic.npz")]
    pub ehm: PathBuf,
    /// Timed repetitions (after one warm-up run).
    #[arg(long, default_value_t = 5)]
    pub iterations: usize,
}

pub fn guava(args: &GuavaBenchArgs) -> anyhow::Result<()> {
    let runtime = OnnxRuntime::load()?;
    let t = Instant::now();
    let mut models = GuavaModels::load_dir(runtime, &args.models)?;
    let load_s = t.elapsed().as_secs_f64();
    let body = EhmModel::load(&args.ehm)?;
    let d = models.dims;
    let t = Instant::now();
    let uv = uv_map(&body, d.uv as u32);
    let uv_ms = t.elapsed().as_secs_f64() * 1e3;
    let portrait = std::path::PathBuf::from(guava::DEMO_PORTRAIT);
    let rgba = image::open(&portrait)?.to_rgba8();
    let image = SourceImage::from_rgba_at(&rgba, None, false, "demo_portrait.png", d.image as u32)?;
    // GUAVA's tracker camera: 22 m away at invtanfov 24, the body upright in view.
    let w2c = Mat4::from_cols_array_2d(&[
        [1.0, 0.0, 0.0, 0.0],
        [0.0, -1.0, 0.0, 0.0],
        [0.0, 0.0, -1.0, 0.0],
        [0.0, 0.2, 22.0, 1.0],
    ]);
    let view = SourceView {
        pose: BodyPose::rest(&body),
        camera: Camera::guava(w2c, SOURCE_SIZE, 24.0),
        crop: None,
    };
    println!(
        "GUAVA mode with {} ({}; {}² image, {}² features and UV map, {} channels), body {:?} \
         ({} valid texels); CPU {}; medians of {}",
        models.dir.display(),
        models.source,
        d.image,
        d.features,
        d.colors,
        body.name,
        uv.len(),
        cpu_name(),
        args.iterations
    );
    println!("{:<34} {:>10}", "stage", "ms");
    println!(
        "{:<34} {:>10.0}",
        "load and check models (once)",
        load_s * 1e3
    );
    println!("{:<34} {:>10.2}", "UV map (once per body)", uv_ms);
    let mut per_stage: Vec<(guava::progress::Stage, Vec<f64>)> = Vec::new();
    let mut totals = Vec::new();
    let mut avatar = None;
    for i in 0..args.iterations + 1 {
        let t0 = Instant::now();
        let (a, report) = reconstruct_guava(
            &mut models,
            &body,
            &uv,
            &view,
            &image,
            "demo_portrait.png",
            &mut |_| true,
        )?;
        if i > 0 {
            totals.push(t0.elapsed().as_secs_f64() * 1e3);
            for (k, (stage, dt)) in report.timings.iter().enumerate() {
                if per_stage.len() <= k {
                    per_stage.push((*stage, Vec::new()));
                }
                per_stage[k].1.push(dt.as_secs_f64() * 1e3);
            }
        }
        avatar = Some(a);
    }
    for (stage, times) in per_stage {
        println!("{:<34} {:>10.2}", stage.name(), median(times));
    }
    println!("{:<34} {:>10.2}", "total per photo", median(totals));
    let avatar = avatar.expect("ran at least once");
    let (mut posed, mut rig, mut cloud) = (
        PosedBody::default(),
        Rig::default(),
        GaussianCloud::new(avatar.channels),
    );
    let mut frame_ms = Vec::new();
    for _ in 0..args.iterations * 4 {
        let t0 = Instant::now();
        body.pose(&view.pose, &mut posed)?;
        rig.animate(&avatar, &posed, &body, &mut cloud)?;
        frame_ms.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    println!(
        "animation per frame ({} Gaussians: {} template, {} UV): pose EHM + rig {:.2} ms",
        avatar.len(),
        avatar.template.len(),
        avatar.uv.local.len(),
        median(frame_ms)
    );
    Ok(())
}
