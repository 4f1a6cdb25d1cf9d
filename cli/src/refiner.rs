//! `guava refiner-pairs`: writes the default refiner's training or held-out pairs
//! (`guava::eval::pairs`) as NumPy arrays for `tools/train_refiner.py`: `inputs.npy`
//! [N, 5, S, S] (RGB, source confidence, alpha of the avatar's splat image) and `targets.npy`
//! [N, 4, S, S] (the subject's premultiplied RGB and coverage), 8-bit, with `views.json` saying
//! which subject, seed and view each row is.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use guava::body::BodyModel;
use guava::eval::pairs::{self, KINDS, SIDE, Split};
use guava::gpu::GpuContext;
use guava::pipeline::Pipeline;
use guava::render::HeadlessRenderer;

pub fn write_pairs(out: &Path, split: Split) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    let body = BodyModel::default_body()?;
    let mut renderer = HeadlessRenderer::new(GpuContext::headless()?);
    let mut pipeline = Pipeline::default();
    let specs = pairs::specs(split);
    let total: usize = specs.iter().map(|s| s.views.len()).sum();
    let n = (SIDE * SIDE) as usize;
    let (mut inputs, mut targets) = (
        Vec::with_capacity(total * 5 * n),
        Vec::with_capacity(total * 4 * n),
    );
    let mut rows = Vec::new();
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    let started = std::time::Instant::now();
    for (k, spec) in specs.iter().enumerate() {
        pairs::make(
            &mut renderer,
            &mut pipeline,
            &body,
            spec,
            &mut |view, pair| {
                let p = &pair.input;
                for plane in [p.plane(0), p.plane(1), p.plane(2), p.plane(3), &p.alpha] {
                    inputs.extend(plane.iter().map(|&v| q(v)));
                }
                targets.extend(
                    pair.target_rgb
                        .iter()
                        .chain(&pair.target_alpha)
                        .map(|&v| q(v)),
                );
                rows.push(serde_json::json!({
                    "subject": KINDS[spec.kind],
                    "seed": spec.seed,
                    "yaw": view.yaw,
                    "pitch": view.pitch,
                    "zoom": view.zoom,
                    "time": view.time,
                }));
            },
        )?;
        eprint!(
            "\rrefiner pairs: {}/{} avatars, {} pairs, {:.0} s",
            k + 1,
            specs.len(),
            rows.len(),
            started.elapsed().as_secs_f32()
        );
    }
    eprintln!();
    let side = SIDE as usize;
    write_npy(
        &out.join("inputs.npy"),
        &[rows.len(), 5, side, side],
        &inputs,
    )?;
    write_npy(
        &out.join("targets.npy"),
        &[rows.len(), 4, side, side],
        &targets,
    )?;
    guava::atomic_file::write_atomic(&out.join("views.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, &rows)?;
        Ok(())
    })?;
    println!("{} pairs of {side}² → {}", rows.len(), out.display());
    Ok(())
}

/// An 8-bit array in NumPy's `.npy` format (version 1.0), written atomically.
fn write_npy(path: &Path, shape: &[usize], data: &[u8]) -> Result<()> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let mut header = format!(
        "{{'descr': '|u1', 'fortran_order': False, 'shape': ({},), }}",
        dims.join(", ")
    );
    // Magic (6) + version (2) + length (2) + header, padded with spaces to 64 bytes, then '\n'.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    header.push('\n');
    guava::atomic_file::write_atomic(path, |w| {
        w.write_all(b"\x93NUMPY\x01\x00")?;
        w.write_all(&(header.len() as u16).to_le_bytes())?;
        w.write_all(header.as_bytes())?;
        w.write_all(data)
    })
    .with_context(|| path.display().to_string())
}
