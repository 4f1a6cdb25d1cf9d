//! `guava bench body`: posing on one CPU core — morphs, joint chain and skinning (vertices plus
//! per-vertex transforms), then the triangle frames — for a few typical loads, on the default body
//! and on an EHM model file.

use std::time::Instant;

use glam::Vec3;

use super::median;
use guava::body::{
    BodyModel, BodyPose, EhmModel, Posable, PosedBody, TargetGroup, triangle_frames,
};
use guava::gaussians::synthetic::Rng;

#[derive(clap::Args, Clone, Debug)]
pub struct BodyBenchArgs {
    /// Timed repetitions per case (after 10 warm-up runs).
    #[arg(long, default_value_t = 300)]
    pub iterations: usize,
    /// EHM model (tools/convert_ehm.py). The default is the synthetic test model, which has the
    /// real model's array sizes (SMPL-X 10,595 vertices with teeth, 350 shape and expression
    /// directions, 486 pose correctives; FLAME 5,143 vertices).
    #[arg(long, default_value = "tests/data/ehm_synthetic.npz")]
    pub ehm: std::path::PathBuf,
}

pub fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|n| n.trim().to_owned())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_owned())
}

/// A benchmark pose: every joint turned when `posed`, and the parameters `active` picks set.
fn case(model: &impl Posable, posed: bool, active: impl Fn(usize, &str) -> bool) -> BodyPose {
    let mut rng = Rng::new(7);
    let mut pose = BodyPose::rest(model);
    if posed {
        for r in &mut pose.rotations {
            *r = Vec3::new(
                rng.range(-0.3, 0.3),
                rng.range(-0.3, 0.3),
                rng.range(-0.3, 0.3),
            );
        }
    }
    for (i, name) in model.parameter_names().enumerate() {
        if active(i, name) {
            pose.coefficients[i] = rng.range(0.0, 0.5);
        }
    }
    pose
}

fn time_cases(model: &impl Posable, cases: &[(&str, BodyPose)], iterations: usize) {
    println!(
        "{:<38} {:>10} {:>10} {:>10}",
        "case", "pose ms", "frames ms", "total ms"
    );
    let mut posed = PosedBody::default();
    let mut frames = Vec::new();
    for (name, pose) in cases {
        let (mut pose_ms, mut frame_ms) = (Vec::new(), Vec::new());
        for i in 0..iterations + 10 {
            let t0 = Instant::now();
            if let Err(e) = model.pose(pose, &mut posed) {
                println!("{name}: {e}");
                return;
            }
            let t1 = Instant::now();
            triangle_frames(&posed.vertices, model.triangles(), &mut frames);
            let t2 = Instant::now();
            if i >= 10 {
                pose_ms.push((t1 - t0).as_secs_f64() * 1e3);
                frame_ms.push((t2 - t1).as_secs_f64() * 1e3);
            }
        }
        let total: Vec<f64> = pose_ms.iter().zip(&frame_ms).map(|(a, b)| a + b).collect();
        println!(
            "{name:<38} {:>10.3} {:>10.3} {:>10.3}",
            median(pose_ms),
            median(frame_ms),
            median(total)
        );
    }
}

pub fn body(args: &BodyBenchArgs) -> anyhow::Result<()> {
    let model = BodyModel::default_body()?;
    println!("cpu: {} (one thread)", cpu_name());
    println!(
        "body: {} — {} vertices, {} triangles, {} joints, {} targets; medians of {} runs",
        model.name,
        model.vertices.len(),
        model.triangles.len(),
        model.joints.len(),
        model.targets.len(),
        args.iterations
    );
    let first_expressions: Vec<usize> = model
        .targets_in(TargetGroup::Expression)
        .take(12)
        .map(|(i, _)| i)
        .collect();
    let cases = [
        ("rest pose", case(&model, false, |_, _| false)),
        ("all joints turned", case(&model, true, |_, _| false)),
        (
            "all joints + 12 expressions",
            case(&model, true, |i, _| first_expressions.contains(&i)),
        ),
        ("all joints + every target", case(&model, true, |_, _| true)),
    ];
    time_cases(&model, &cases, args.iterations);

    let ehm = match EhmModel::load(&args.ehm) {
        Ok(ehm) => ehm,
        Err(e) => {
            println!("\nEHM skipped: {e}");
            return Ok(());
        }
    };
    println!(
        "\nEHM: {} — {} vertices ({} head), {} triangles, 55 joints, {} parameters",
        args.ehm.display(),
        ehm.body.template.len(),
        ehm.head.template.len(),
        ehm.triangles.len(),
        ehm.parameter_names().len()
    );
    let face = |n: &str| {
        n.starts_with("expression_")
            || n.starts_with("flame_expression_")
            || n.starts_with("eyelid")
    };
    let cases = [
        ("rest pose", case(&ehm, false, |_, _| false)),
        ("all joints turned", case(&ehm, true, |_, _| false)),
        (
            "all joints + 100 expressions + eyelids",
            case(&ehm, true, |_, n| face(n)),
        ),
        (
            "all joints + every parameter",
            case(&ehm, true, |_, _| true),
        ),
    ];
    time_cases(&ehm, &cases, args.iterations);
    Ok(())
}
