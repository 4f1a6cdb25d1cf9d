//! `guava bench fidelity`: how much the avatar looks like its photo. The synthetic subjects
//! (bare, in a jacket, with hair, both) reconstructed from a front photo and compared with their
//! known geometry from the source view, turned views and a new pose; then the real photos in the
//! repository (the demo portrait, the cameraman) from their own views, with each stage's time.

use std::path::Path;

use anyhow::Context;
use guava::body::BodyModel;
use guava::eval::side_by_side;
use guava::eval::subjects::{VIEWS, score};
use guava::gpu::GpuContext;
use guava::pipeline::{Mode, Photo, Pipeline, Tracked};
use guava::render::{HeadlessRenderer, save_png};
use guava::synthetic::Subject;

use super::body::cpu_name;

#[derive(clap::Args, Clone, Debug)]
pub struct FidelityBenchArgs {
    /// A folder for each synthetic subject's truth | render | difference at every view
    /// (`<subject>_<view>.png`), to look at what the rows score.
    #[arg(long)]
    out: Option<std::path::PathBuf>,
}

pub fn fidelity(args: &FidelityBenchArgs) -> anyhow::Result<()> {
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    }
    let body = BodyModel::default_body()?;
    let mut renderer = HeadlessRenderer::new(GpuContext::headless()?);
    let mut pipeline = Pipeline::default();
    println!(
        "{}; CPU {}\n\nsynthetic subjects, reconstructed from a front photo with their exact view:",
        renderer.gpu.adapter_label(),
        cpu_name()
    );
    println!(
        "{:<20} {:<16} {:>7} {:>7} {:>7} {:>7}",
        "subject", "view", "IoU", "PSNR", "SSIM", "L1"
    );
    for subject in [
        Subject::bare(&body),
        Subject::clothed(&body),
        Subject::haired(&body),
        Subject::clothed_and_haired(&body),
        Subject::long_haired(&body),
    ] {
        let mut written = Ok(());
        let rows = score(
            &mut renderer,
            &mut pipeline,
            &subject,
            |view, truth, rendered| {
                if let (Some(dir), Ok(())) = (&args.out, &written) {
                    let name = format!("{} {view}", subject.name)
                        .replace('−', "-")
                        .replace(['°', '(', ')'], "")
                        .replace(
                            |c: char| !c.is_ascii_alphanumeric() && !"+-".contains(c),
                            "_",
                        );
                    let name = format!("{}.png", name.trim_end_matches('_'));
                    written = save_png(&side_by_side(truth, rendered), &dir.join(name));
                }
            },
        )?;
        written?;
        for ((view, ..), m) in VIEWS.iter().zip(rows) {
            println!(
                "{:<20} {view:<16} {:>7.4} {:>7.2} {:>7.4} {:>7.4}",
                subject.name, m.iou, m.psnr, m.ssim, m.l1
            );
        }
    }
    println!("\nreal photos, from their own views (fitted; the mask is the pose model's):");
    let root = Path::new(guava::REPO);
    for photo in ["assets/demo_portrait.png", "tests/data/camera.png"] {
        let path = root.join(photo);
        let outcome = pipeline.reconstruct(
            Mode::Default(&body),
            Photo::File(&path),
            Tracked::Fit,
            &mut |_| true,
        )?;
        let image = pipeline.masked_photo(Photo::File(&path), &outcome.view, &mut |_| true)?;
        let (m, _) = guava::eval::evaluate(&mut renderer, &outcome.avatar, &body, None, &image)?;
        println!("{photo}: {m}");
        let stages: Vec<String> = outcome
            .report
            .timings
            .iter()
            .map(|(s, d)| format!("{} {:.0} ms", s.name(), d.as_secs_f64() * 1e3))
            .collect();
        println!("  {}", stages.join(", "));
    }
    Ok(())
}
