//! The real photos in the repository per UV map side: each photo fitted once, then
//! reconstructed at every side (timed, the fit given) and compared with itself from its own
//! camera (`guava eval`'s measure). The synthetic subject's sweep knows the truth from every
//! view; these say what the knob does to real photos, from the one view they have.

use std::path::Path;

use anyhow::Result;
use guava::body::BodyModel;
use guava::pipeline::{Mode, Photo, Pipeline, Tracked};
use guava::render::HeadlessRenderer;

use super::Table;

pub fn run(
    renderer: &mut HeadlessRenderer,
    pipeline: &mut Pipeline,
    body: &BodyModel,
    uv_sides: &[u32],
    quick: bool,
) -> Result<Table> {
    let root = Path::new(guava::REPO);
    let photos: &[&str] = if quick {
        &["assets/demo_portrait.png"]
    } else {
        &["assets/demo_portrait.png", "tests/data/camera.png"]
    };
    let mut table = Table {
        header: vec![
            "photo",
            "uv",
            "gaussians",
            "reconstruct_ms",
            "iou",
            "psnr_db",
            "ssim",
            "l1",
        ],
        rows: Vec::new(),
    };
    let default_side = pipeline.uv_size;
    for photo in photos {
        let path = root.join(photo);
        let fitted = pipeline.reconstruct(
            Mode::Default(body),
            Photo::File(&path),
            Tracked::Fit,
            &mut |_| true,
        )?;
        let image = pipeline.masked_photo(Photo::File(&path), &fitted.view, &mut |_| true)?;
        for &uv in uv_sides {
            pipeline.uv_size = uv;
            let reconstruct = |pipeline: &mut Pipeline| {
                pipeline.reconstruct(
                    Mode::Default(body),
                    Photo::File(&path),
                    Tracked::Given(fitted.view.clone()),
                    &mut |_| true,
                )
            };
            // Once to make the side's UV map (kept), once timed.
            reconstruct(pipeline)?;
            let started = std::time::Instant::now();
            let outcome = reconstruct(pipeline)?;
            let ms = started.elapsed().as_secs_f64() * 1e3;
            let (m, _) = guava::eval::evaluate(renderer, &outcome.avatar, body, None, &image)?;
            table.rows.push(vec![
                photo.to_string(),
                uv.to_string(),
                outcome.avatar.len().to_string(),
                format!("{ms:.0}"),
                format!("{:.4}", m.iou),
                format!("{:.2}", m.psnr),
                format!("{:.4}", m.ssim),
                format!("{:.4}", m.l1),
            ]);
        }
    }
    pipeline.uv_size = default_side;
    Ok(table)
}
