//! A long session, shortened for CI: the viewer plays the demo motion, orbits, switches views and
//! opens an avatar file again and again (each time a new avatar replaces the last on the GPU),
//! with its resident memory sampled after every round. After a warm-up the memory must stop
//! growing: the last rounds may not hold more than a bound above the warm-up's level. The rounds
//! and the figures are printed (`cargo test -p guava-ui --test soak -- --nocapture`);
//! `GUAVA_SOAK_ROUNDS` runs longer.

use std::time::{Duration, Instant};

use egui_kittest::Harness;
use guava_ui::{GuavaApp, Options, View};

/// Resident memory of this process in MiB (Linux's /proc; `None` elsewhere).
fn rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn frame(h: &mut Harness<'static, GuavaApp>) {
    h.step();
    h.render().expect("frame renders");
}

/// Growth allowed after the warm-up: the allocator and the driver keep some pools, but a leak
/// of one avatar per round (its ~180k Gaussians are ~25 MiB on the GPU side and in the CPU copy)
/// would pass it within a few rounds.
const BOUND_MIB: f64 = 48.0;
const WARM_UP: usize = 4;

#[test]
fn a_long_session_does_not_grow() {
    let Some(start) = rss_mib() else {
        eprintln!("no /proc/self/status: memory is not sampled on this platform");
        return;
    };
    let rounds: usize = std::env::var("GUAVA_SOAK_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(12);
    // An avatar file to open repeatedly: the synthetic photo's default reconstruction.
    let dir = std::env::temp_dir().join(format!("guava-soak-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let avatar_file = dir.join("soak.guava");
    {
        use guava::body::BodyModel;
        use guava::eval::subjects::reconstruct_subject;
        use guava::synthetic::{Subject, subject_texture};
        let body = BodyModel::default_body().expect("body");
        let mut pipeline = guava::pipeline::Pipeline::default();
        let outcome = reconstruct_subject(&mut pipeline, &Subject::clothed(&body), subject_texture)
            .expect("reconstructs");
        outcome.avatar.save(&avatar_file).expect("saves");
    }

    let mut h = Harness::builder()
        .with_size(egui::vec2(900.0, 600.0))
        .wgpu()
        .build_eframe(|cc| {
            GuavaApp::new(
                cc,
                Options {
                    autoplay: true,
                    ..Default::default()
                },
            )
        });
    h.step();
    let began = Instant::now();
    let mut samples = Vec::new();
    for round in 0..rounds {
        assert!(
            h.state().avatar_info().is_some() || round == 0,
            "the avatar stays shown"
        );
        h.state_mut().open(avatar_file.clone());
        let opened = Instant::now();
        while h.state().busy() && opened.elapsed() < Duration::from_secs(30) {
            h.step();
            std::thread::sleep(Duration::from_millis(10));
        }
        for (k, view) in [View::Avatar, View::Body, View::Avatar]
            .into_iter()
            .enumerate()
        {
            h.state_mut().set_view(view);
            h.state_mut().set_yaw_deg(30.0 * (round * 3 + k) as f32);
            frame(&mut h);
            frame(&mut h);
        }
        samples.push(rss_mib().expect("sampled above"));
    }
    let elapsed = began.elapsed().as_secs_f64();
    let warm = samples[WARM_UP.min(samples.len() - 1)];
    let peak_after = samples[WARM_UP.min(samples.len() - 1)..]
        .iter()
        .copied()
        .fold(f64::MIN, f64::max);
    let last = *samples.last().expect("rounds");
    println!(
        "soak: {rounds} rounds in {elapsed:.0} s; resident memory {start:.0} MiB at start, \
         {warm:.0} after {WARM_UP} rounds of warm-up, peak {peak_after:.0}, last {last:.0} \
         (per round: {})",
        samples
            .iter()
            .map(|m| format!("{m:.0}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    assert!(
        peak_after - warm <= BOUND_MIB,
        "resident memory grew {:.0} MiB after the warm-up (bound {BOUND_MIB})",
        peak_after - warm
    );
    std::fs::remove_dir_all(&dir).ok();
}
