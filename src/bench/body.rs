//! `guava bench body`: posing the default body on one CPU core — morphs, joint chain and skinning
//! (vertices plus per-vertex transforms), then the triangle frames — for a few typical loads.

use std::time::Instant;

use glam::Vec3;

use super::median;
use crate::body::{BodyModel, BodyPose, PosedBody, TargetGroup, triangle_frames};
use crate::gaussians::synthetic::Rng;

#[derive(clap::Args, Clone, Debug)]
pub struct BodyBenchArgs {
    /// Timed repetitions per case (after 10 warm-up runs).
    #[arg(long, default_value_t = 300)]
    pub iterations: usize,
}

fn cpu_name() -> String {
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

/// The benchmark poses: `expressions` of the face targets active, every joint turned when `posed`.
fn case(model: &BodyModel, posed: bool, expressions: usize, shapes: bool) -> BodyPose {
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
    for (i, _) in model.targets_in(TargetGroup::Expression).take(expressions) {
        pose.coefficients[i] = rng.f32();
    }
    if shapes {
        for (i, _) in model.targets_in(TargetGroup::Shape) {
            pose.coefficients[i] = rng.range(0.0, 0.5);
        }
    }
    pose
}

pub fn body(args: &BodyBenchArgs) -> anyhow::Result<()> {
    let model = BodyModel::default_body()?;
    let expressions = model.targets_in(TargetGroup::Expression).count();
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
    println!(
        "{:<38} {:>10} {:>10} {:>10}",
        "case", "pose ms", "frames ms", "total ms"
    );
    let cases = [
        ("rest pose", case(&model, false, 0, false)),
        ("all joints turned", case(&model, true, 0, false)),
        ("all joints + 12 expressions", case(&model, true, 12, false)),
        (
            "all joints + every target",
            case(&model, true, expressions, true),
        ),
    ];
    let mut posed = PosedBody::default();
    let mut frames = Vec::new();
    for (name, pose) in &cases {
        let (mut pose_ms, mut frame_ms) = (Vec::new(), Vec::new());
        for i in 0..args.iterations + 10 {
            let t0 = Instant::now();
            model.pose(pose, &mut posed)?;
            let t1 = Instant::now();
            triangle_frames(&posed.vertices, &model.triangles, &mut frames);
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
    Ok(())
}
