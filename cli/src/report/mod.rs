//! `guava report`: what this machine's avatars cost and how wrong they are, in one folder —
//! error against run time over the quality knobs with the Pareto front ([`tradeoffs`]), how the
//! pipeline holds up on stiff and extreme inputs ([`stability`]), and what leaving work out saves
//! ([`savings`]), and the real photos per UV side ([`photos`]): `report.md` with the machine and
//! adapter, CSV per section and an SVG plot.
//! `--quick` runs a few small settings (the test suite runs it on lavapipe).

mod photos;
mod plot;
mod savings;
mod stability;
mod tradeoffs;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use guava::body::BodyModel;
use guava::gpu::GpuContext;
use guava::pipeline::Pipeline;
use guava::render::HeadlessRenderer;
use guava::synthetic::{Subject, subject_texture};

use crate::bench::cpu_name;

#[derive(clap::Args, Clone, Debug)]
pub struct ReportArgs {
    /// The folder to write (created; its report files are replaced).
    #[arg(long)]
    out: PathBuf,
    /// A few small settings, for CI: sides 128 and 256, 3 repeats.
    #[arg(long)]
    quick: bool,
}

/// One CSV table: a header and rows of cells.
pub struct Table {
    pub header: Vec<&'static str>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    fn csv(&self) -> String {
        let mut s = self.header.join(",") + "\n";
        for row in &self.rows {
            let cells: Vec<String> = row
                .iter()
                .map(|c| match c.contains([',', '"']) {
                    true => format!("\"{}\"", c.replace('"', "\"\"")),
                    false => c.clone(),
                })
                .collect();
            s += &(cells.join(",") + "\n");
        }
        s
    }

    fn markdown(&self) -> String {
        let mut s = format!("| {} |\n", self.header.join(" | "));
        s += &format!("|{}\n", "---|".repeat(self.header.len()));
        for row in &self.rows {
            s += &format!("| {} |\n", row.join(" | "));
        }
        s
    }
}

pub fn report(args: &ReportArgs) -> Result<()> {
    let out = &args.out;
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    let body = BodyModel::default_body()?;
    let mut renderer = HeadlessRenderer::new(GpuContext::headless()?);
    let mut pipeline = Pipeline::default();
    let machine = format!("{}; CPU {}", renderer.gpu.adapter_label(), cpu_name());
    eprintln!("report: {machine}");

    // The subject every section draws: jacket and hair, reconstructed from its front photo at
    // the default UV side (first) and at the other sides the sweep compares.
    let subject = Subject::clothed_and_haired(&body);
    let other_sides: &[u32] = if args.quick { &[128] } else { &[128, 256, 512] };
    let mut candidates = Vec::new();
    for uv in
        std::iter::once(guava::reconstruct::DEFAULT_UV_SIZE).chain(other_sides.iter().copied())
    {
        pipeline.uv_size = uv;
        // Once to build the UV map (kept by the pipeline for its side), once timed.
        guava::eval::subjects::reconstruct_subject(&mut pipeline, &subject, subject_texture)?;
        let started = std::time::Instant::now();
        let outcome =
            guava::eval::subjects::reconstruct_subject(&mut pipeline, &subject, subject_texture)?;
        candidates.push(tradeoffs::Candidate {
            uv,
            reconstruct_ms: started.elapsed().as_secs_f64() * 1e3,
            avatar: outcome.avatar,
        });
    }
    pipeline.uv_size = guava::reconstruct::DEFAULT_UV_SIZE;
    let avatar = &candidates[0].avatar;

    eprintln!("report: error against run time");
    let trade = tradeoffs::run(&mut renderer, &subject, &candidates, args.quick)?;
    eprintln!("report: the real photos");
    let sides: Vec<u32> = candidates.iter().map(|c| c.uv).collect();
    let real = photos::run(&mut renderer, &mut pipeline, &body, &sides, args.quick)?;
    eprintln!("report: stability");
    let stable = stability::run(&mut renderer, &mut pipeline, &body, avatar)?;
    eprintln!("report: leaving work out");
    let saved = savings::run(&mut renderer, &body, avatar, args.quick)?;

    let write = |name: &str, text: &str| -> Result<()> {
        let path = out.join(name);
        guava::atomic_file::write_atomic(&path, |w| std::io::Write::write_all(w, text.as_bytes()))
            .with_context(|| path.display().to_string())
    };
    write("tradeoffs.csv", &trade.table.csv())?;
    write("stability.csv", &stable.table.csv())?;
    write("savings.csv", &saved.csv())?;
    write("photos.csv", &real.csv())?;
    write("tradeoffs.svg", &plot::svg(&trade.points))?;

    let mut md = String::new();
    let _ = writeln!(
        md,
        "# guava report{}\n",
        if args.quick { " (quick)" } else { "" }
    );
    let _ = writeln!(
        md,
        "Machine: {machine}. Subject: the synthetic subject in a jacket with hair, reconstructed in default mode from its front photo, seen from yaw 30° (error against its own ground truth). Times are medians; absolute times on a shared machine are indicative.\n"
    );
    let _ = writeln!(
        md,
        "## Error against run time\n\n![PSNR against time](tradeoffs.svg)\n"
    );
    let _ = writeln!(md, "{}", trade.table.markdown());
    let _ = writeln!(md, "{}\n", trade.note);
    let _ = writeln!(
        md,
        "## The real photos per UV side\n\nEach photo fitted once, reconstructed at each side \
         (timed, photo → avatar with the fit given) and compared with itself from its own camera \
         over the person's box (`guava eval`); the mask is the pose model's.\n\n{}",
        real.markdown()
    );
    let _ = writeln!(md, "## Stability\n\n{}", stable.table.markdown());
    let _ = writeln!(md, "{}\n", stable.note);
    let _ = writeln!(
        md,
        "## Leaving out what a scene does not need\n\n{}",
        saved.markdown()
    );
    write("report.md", &md)?;
    println!(
        "{} settings ({} on the Pareto front), {} stability cases ({}), {} savings → {}",
        trade.table.rows.len(),
        trade.points.iter().filter(|p| p.pareto).count(),
        stable.table.rows.len(),
        if stable.passed {
            "all pass"
        } else {
            "FAILURES"
        },
        saved.rows.len(),
        Path::new(out).join("report.md").display()
    );
    if !stable.passed {
        anyhow::bail!(
            "a stability case failed: see {}",
            out.join("stability.csv").display()
        );
    }
    Ok(())
}

/// Median of `reps` timings of `f` in milliseconds.
pub fn time_ms(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..reps)
        .map(|_| {
            let t = std::time::Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}
