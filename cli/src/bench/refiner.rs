//! `guava bench refiner`: the default refiner on the held-out pairs (subjects, views and poses
//! it was not trained on): raw splat RGB and refined, each against the ground truth, per subject
//! kind; then what refining costs per frame where it runs (ONNX Runtime on the CPU, after reading
//! the splat image back) at the viewer's sizes.

use std::path::PathBuf;
use std::time::Instant;

use guava::body::BodyModel;
use guava::eval::Metrics;
use guava::eval::pairs::{self, KINDS, Split};
use guava::gpu::GpuContext;
use guava::onnx::OnnxRuntime;
use guava::pipeline::Pipeline;
use guava::refine::{DEFAULT_REFINER, Refiner};
use guava::render::{HeadlessRenderer, SplatImage};

use super::body::cpu_name;
use super::median;

#[derive(clap::Args, Clone, Debug)]
pub struct RefinerBenchArgs {
    /// The refiner model (default: the shipped default refiner).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Also time GUAVA's refiner (`guava_refiner.onnx`; full size with random weights from
    /// `tools/export_guava_onnx.py --random 0 --only refiner`) per frame at its own side.
    #[arg(long)]
    guava_refiner: Option<PathBuf>,
    /// Only the per-frame times (skip the held-out pairs).
    #[arg(long)]
    frames_only: bool,
}

#[derive(Default)]
struct Sums {
    n: usize,
    raw: [f64; 3],
    refined: [f64; 3],
}

impl Sums {
    fn add(&mut self, raw: Metrics, refined: Metrics) {
        self.n += 1;
        for (s, m) in [(&mut self.raw, raw), (&mut self.refined, refined)] {
            s[0] += m.psnr;
            s[1] += m.ssim;
            s[2] += m.iou;
        }
    }

    fn row(&self, name: &str) {
        let n = self.n.max(1) as f64;
        let [a, b] = [self.raw, self.refined].map(|s| s.map(|v| v / n));
        println!(
            "{name:<20} {:>5} {:>8.2} {:>8.2} {:>+7.2} {:>8.4} {:>8.4} {:>8.4} {:>8.4}",
            self.n,
            a[0],
            b[0],
            b[0] - a[0],
            a[1],
            b[1],
            a[2],
            b[2]
        );
    }
}

pub fn refiner(args: &RefinerBenchArgs) -> anyhow::Result<()> {
    let model = args.model.clone().unwrap_or_else(|| DEFAULT_REFINER.into());
    let mut refiner = Refiner::load(OnnxRuntime::load()?, &model)?;
    let mut renderer = HeadlessRenderer::new(GpuContext::headless()?);
    println!(
        "{}: {}\n{}; CPU {}\n",
        model.display(),
        refiner.description,
        renderer.gpu.adapter_label(),
        cpu_name()
    );
    if !args.frames_only {
        held_out(&mut refiner, &mut renderer)?;
    }
    let started = Instant::now();
    let mut wgsl = Refiner::load_wgsl(&renderer.gpu, &model);
    let compile_ms = started.elapsed().as_secs_f64() * 1e3;
    per_frame(&mut refiner, wgsl.as_mut().ok(), &mut renderer)?;
    match &wgsl {
        Ok(_) => println!(
            "(WGSL: reading the model and building its pipelines took {compile_ms:.0} ms; it \
             adds no crate to the build)"
        ),
        Err(e) => println!("WGSL passes not measured: {e}"),
    }
    if let Some(path) = &args.guava_refiner {
        guava_refiner(path, &renderer.gpu)?;
    }
    Ok(())
}

/// Raw and refined against the truth on the held-out pairs, per subject kind: new textures on
/// the training bodies, then unseen bodies in unseen poses only.
fn held_out(refiner: &mut Refiner, renderer: &mut HeadlessRenderer) -> anyhow::Result<()> {
    let body = BodyModel::default_body()?;
    let mut pipeline = Pipeline::default();
    for (split, what) in [
        (
            Split::HeldOut,
            "held-out pairs (seeds, yaws ±30°/±60° and poses not trained on; the training's \
             bodies, a third in the rest pose)",
        ),
        (
            Split::UnseenBodies,
            "unseen bodies (shapes not trained on: heavier and shorter, taller with other \
             proportions; held-out seeds and yaws; poses from the motion's second half only)",
        ),
    ] {
        println!("{what}, mean per pair:");
        split_table(refiner, renderer, &mut pipeline, &body, split)?;
        println!();
    }
    Ok(())
}

fn split_table(
    refiner: &mut Refiner,
    renderer: &mut HeadlessRenderer,
    pipeline: &mut Pipeline,
    body: &BodyModel,
    split: Split,
) -> anyhow::Result<()> {
    println!(
        "{:<20} {:>5} {:>8} {:>8} {:>7} {:>8} {:>8} {:>8} {:>8}",
        "subject",
        "pairs",
        "PSNR raw",
        "refined",
        "gain",
        "SSIM raw",
        "refined",
        "IoU raw",
        "refined"
    );
    let mut per_kind: Vec<Sums> = KINDS.iter().map(|_| Sums::default()).collect();
    let mut all = Sums::default();
    let mut failed = None;
    for spec in pairs::specs(split) {
        pairs::make(renderer, pipeline, body, &spec, &mut |_, pair| {
            let refined = match refiner.refine(&pair.input) {
                Ok(r) => r,
                Err(e) => return failed = Some(e),
            };
            if let (Some(raw), Some(fine)) = (pair.score(&pair.input), pair.score(&refined)) {
                per_kind[spec.kind].add(raw, fine);
                all.add(raw, fine);
            }
        })?;
        if let Some(e) = failed.take() {
            return Err(e.into());
        }
    }
    for (kind, sums) in KINDS.iter().zip(&per_kind) {
        sums.row(kind);
    }
    all.row("all");
    Ok(())
}

/// Per frame, at the viewer's sizes: reading the splat image back and refining it with ONNX
/// Runtime, against our own WGSL passes reading the splat layers where they lie.
fn per_frame(
    onnx: &mut Refiner,
    mut wgsl: Option<&mut Refiner>,
    renderer: &mut HeadlessRenderer,
) -> anyhow::Result<()> {
    println!(
        "\nper frame, medians of 5: (a) read the splat image back, ONNX Runtime on the CPU; (b) \
         WGSL passes on the splatting device (gather the layers, run, read the output back)"
    );
    println!(
        "{:<12} {:>12} {:>12} {:>10} {:>10}",
        "size", "readback ms", "ORT ms", "(a) ms", "(b) ms"
    );
    // A default avatar's layout: RGB and a confidence channel.
    let knot = guava::gaussians::synthetic::torus_knot(10_000, 4);
    let mut cloud = guava::gaussians::GaussianCloud::new(4);
    for i in 0..knot.len() {
        let rgb = knot.features_of(i);
        cloud.push(
            knot.positions[i],
            knot.rotations[i],
            knot.scales[i],
            knot.opacities[i],
            &[rgb[0], rgb[1], rgb[2], 1.0],
        );
    }
    for (w, h) in [(256u32, 256u32), (512, 512), (768, 704)] {
        let camera = guava::camera::Camera::from_fov_y(
            guava::camera::orbit(glam::Vec3::ZERO, 3.0, 0.3, 0.2),
            w,
            h,
            0.8,
        );
        renderer.render(&cloud, &camera, &[0.0; 4])?;
        let (mut readback, mut refine, mut on_device) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..5 {
            let t = Instant::now();
            let image = renderer
                .splatter
                .read_image(&renderer.gpu.device, &renderer.gpu.queue)
                .unwrap_or_else(|| SplatImage::new(w, h, 4));
            readback.push(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            onnx.refine(&image)?;
            refine.push(t.elapsed().as_secs_f64() * 1e3);
            if let Some(wgsl) = wgsl.as_deref_mut() {
                let t = Instant::now();
                wgsl.refine_drawn(renderer)?;
                on_device.push(t.elapsed().as_secs_f64() * 1e3);
            }
        }
        let (readback, refine) = (median(readback), median(refine));
        let b = if on_device.is_empty() {
            "-".to_string()
        } else {
            format!("{:.1}", median(on_device))
        };
        println!(
            "{:<12} {:>12.1} {:>12.1} {:>10.1} {:>10}",
            format!("{w}×{h}"),
            readback,
            refine,
            readback + refine,
            b
        );
    }
    Ok(())
}

/// GUAVA's refiner per frame at its own side (no resampling), on a deterministic feature image
/// (the network's cost does not depend on the values).
fn guava_refiner(path: &std::path::Path, gpu: &GpuContext) -> anyhow::Result<()> {
    let mut refiner = Refiner::load(OnnxRuntime::load()?, path)?;
    let guava::refine::RefinerKind::Guava { channels, side } = refiner.kind else {
        anyhow::bail!("{}: not GUAVA's refiner (its metadata)", path.display());
    };
    let mut image = SplatImage::new(side as u32, side as u32, channels);
    for (i, v) in image.features.iter_mut().enumerate() {
        *v = ((i * 7919) % 1000) as f32 / 1000.0 - 0.5;
    }
    image.alpha.fill(1.0);
    let mut times = Vec::new();
    for _ in 0..3 {
        let t = Instant::now();
        refiner.refine(&image)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    println!(
        "
{}: {} at {side}², {channels} channels: {:.0} ms per frame (median of 3, ONNX Runtime \
         on the CPU)",
        path.display(),
        refiner.description,
        median(times)
    );
    // Our own passes run the operators a small U-Net uses; StyleUNet's modulated convolutions
    // are not among them: say which operator stops it.
    if let Err(e) = Refiner::load_wgsl(gpu, path) {
        println!("WGSL passes: {e}");
    }
    Ok(())
}
