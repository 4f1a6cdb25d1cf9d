//! `guava bench reconstruct`: the default reconstruction of a synthetic photo of the default body
//! on one CPU thread, per stage (the UV map is built once per body and timed apart), then
//! animating the avatar for one frame of the demo motion (posing + rigging its Gaussians), the
//! single-image fit of the demo portrait (also on an EHM body, through its linear body), and the
//! cost of framing photos the centred square does not suit.

use std::time::{Duration, Instant};

use super::body::cpu_name;
use super::median;
use guava::avatar::Rig;
use guava::body::{BodyModel, BodyPose, EhmModel, PosedBody};
use guava::fit::{FitInput, embed_face, fit_keypoints};
use guava::gaussians::GaussianCloud;
use guava::keypoints::{Landmarkers, Wholebody};
use guava::onnx::OnnxRuntime;
use guava::photo::SourceImage;
use guava::progress::Stage;
use guava::reconstruct::{DEFAULT_UV_SIZE, UvMap, reconstruct_default};
use guava::synthetic::{banded_texture, photo, upper_body_camera};
use guava::tracking::SourceView;
use guava::tracking::{Retarget, demo_motion};

#[derive(clap::Args, Clone, Debug)]
pub struct ReconstructBenchArgs {
    /// Timed repetitions (after 2 warm-up runs).
    #[arg(long, default_value_t = 20)]
    pub iterations: usize,
    /// Also time the fit of the demo portrait on this EHM body (tools/convert_ehm.py), with
    /// the making of its linear body.
    #[arg(long)]
    pub ehm: Option<std::path::PathBuf>,
    /// Also time EHM-Tracker's keypoint models (YOLOX + DWPose, its checkpoint folder) on the
    /// demo portrait.
    #[arg(long)]
    pub dwpose: Option<std::path::PathBuf>,
}

pub fn reconstruct(args: &ReconstructBenchArgs) -> anyhow::Result<()> {
    let body = BodyModel::default_body()?;
    let t = Instant::now();
    let uv = UvMap::for_body(&body, DEFAULT_UV_SIZE);
    let uv_ms = t.elapsed().as_secs_f64() * 1e3;
    let view = SourceView {
        pose: BodyPose::rest(&body),
        camera: upper_body_camera(&body, 0.3),
        crop: None,
    };
    let image = photo(&body, &view.pose, &view.camera, banded_texture)?;
    println!(
        "default reconstruction of a synthetic 512² photo of the default body ({} valid texels of {}²), \
         one thread on {}, medians of {}",
        uv.len(),
        uv.size,
        cpu_name(),
        args.iterations
    );
    let mut per_stage: Vec<Vec<f64>> = vec![Vec::new(); Stage::DEFAULT.len() + 2];
    let mut avatar = None;
    for i in 0..args.iterations + 2 {
        let t0 = Instant::now();
        let source = SourceImage::from_rgba(&image, true, "synthetic")?;
        let load = t0.elapsed();
        let (a, report) =
            reconstruct_default(&body, &uv, &view, source, "synthetic", &mut |_| true)?;
        if i >= 2 {
            per_stage[0].push(ms(load));
            for (k, (_, d)) in report.timings.iter().enumerate() {
                per_stage[k + 1].push(ms(*d));
            }
            per_stage[Stage::DEFAULT.len() + 1].push(ms(t0.elapsed()));
        }
        avatar = Some(a);
    }
    let avatar = avatar.expect("ran at least once");
    println!("{:<34} {:>10}", "stage", "ms");
    println!("{:<34} {:>10.2}", "UV map + mirror (once per body)", uv_ms);
    let names = std::iter::once("crop + resize + mask")
        .chain(Stage::DEFAULT.iter().map(|s| s.name()))
        .chain(std::iter::once("total per photo"));
    for (name, times) in names.zip(per_stage) {
        println!("{:<34} {:>10.2}", name, median(times));
    }

    // One frame of animation: pose the body from the demo motion, rig the Gaussians.
    let motion = demo_motion()?;
    let retarget = Retarget::new(&motion, &body);
    let mut pose = BodyPose::rest(&body);
    let (mut posed, mut rig, mut cloud) =
        (PosedBody::default(), Rig::default(), GaussianCloud::new(4));
    let (mut pose_ms, mut rig_ms) = (Vec::new(), Vec::new());
    for i in 0..args.iterations * 5 + 5 {
        let time = i as f64 / 30.0 % motion.duration();
        let t0 = Instant::now();
        retarget.sample(&motion, time, &mut pose);
        avatar.apply_identity(&body, &mut pose);
        body.pose(&pose, &mut posed)?;
        let t1 = Instant::now();
        rig.animate(&avatar, &posed, &body, &mut cloud)?;
        if i >= 5 {
            pose_ms.push(ms(t1 - t0));
            rig_ms.push(ms(t1.elapsed()));
        }
    }
    println!(
        "animation per frame ({} Gaussians): pose body {:.2} ms, rig Gaussians {:.2} ms",
        avatar.len(),
        median(pose_ms),
        median(rig_ms)
    );
    fit_demo_portrait(&body, args.iterations)?;
    framing_cost(args.iterations)?;
    if let Some(path) = &args.ehm {
        let ehm = EhmModel::load(path)?;
        let mut linearise_ms = Vec::new();
        let mut linear = None;
        for _ in 0..args.iterations.min(10) {
            let t = Instant::now();
            linear = Some(ehm.linearised());
            linearise_ms.push(ms(t.elapsed()));
        }
        let linear = linear.unwrap_or_else(|| ehm.linearised());
        println!(
            "EHM {:?}: its linear body for fitting made in {:.1} ms ({} vertices, {} targets)",
            ehm.name,
            median(linearise_ms),
            linear.vertices.len(),
            linear.targets.len()
        );
        fit_demo_portrait(&linear, args.iterations)?;
    }
    if let Some(dir) = &args.dwpose {
        wholebody_on_demo_portrait(dir, args.iterations)?;
    }
    Ok(())
}

/// Reading a photo for the fit (decoding, framing, every keypoint model on the chosen square)
/// where the centred square will do (the demo portrait) and where it has to be reframed,
/// side by side.
fn framing_cost(iterations: usize) -> anyhow::Result<()> {
    use guava::pipeline::{Framing, SourcePhoto, Square};
    use guava::synthetic::portrait_placed;
    let dir = std::env::temp_dir().join(format!("guava-bench-framing-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let mut photos = vec![(
        "demo portrait 512² (kept)".to_string(),
        std::path::PathBuf::from(guava::DEMO_PORTRAIT),
    )];
    for (name, size, at) in [
        ("portrait at the left of 1024×512", [1024, 512], [0, 0]),
        ("portrait at the top of 512×1024", [512, 1024], [0, 0]),
        ("portrait small in 1600²", [1600, 1600], [544, 700]),
    ] {
        let path = dir.join(format!("{}.png", photos.len()));
        portrait_placed(size, at)?.save(&path)?;
        photos.push((name.to_string(), path));
    }
    let mut models = Landmarkers::load(OnnxRuntime::load()?)?;
    println!("reading a photo for the fit (decode, frame, every keypoint model), medians:");
    let mut baseline = None;
    for (name, path) in &photos {
        let mut times = Vec::new();
        let mut crop = None;
        for i in 0..iterations.min(10) + 1 {
            let t = Instant::now();
            let square = Square::Fitted(Framing::KeepCentred);
            crop = SourcePhoto::read(path, square, Some(&mut models), &mut |_| true)?.crop;
            if i > 0 {
                times.push(ms(t.elapsed()));
            }
        }
        let time = median(times);
        let base = *baseline.get_or_insert(time);
        let framed = crop.map_or("centred square".into(), |c| {
            format!("framed {}² at ({}, {})", c.side, c.left, c.top)
        });
        println!("  {name:34} {time:7.1} ms  {:4.2}×  {framed}", time / base);
    }
    std::fs::remove_dir_all(&dir).ok();
    Ok(())
}

/// EHM-Tracker's models (ONNX Runtime, its default CPU threads) on the demo portrait: people,
/// then DWPose in each person's crop, with their OpenCV-exact preparation and decoding.
fn wholebody_on_demo_portrait(dir: &std::path::Path, iterations: usize) -> anyhow::Result<()> {
    let path = std::path::PathBuf::from(guava::DEMO_PORTRAIT);
    let source = SourceImage::load(&path)?;
    let mut models = Wholebody::load_dir(OnnxRuntime::load()?, dir)?;
    let mut times = Vec::new();
    let mut people = 0;
    for i in 0..iterations.min(10) + 1 {
        let t = Instant::now();
        people = models.detect(&source)?.people.len();
        if i > 0 {
            times.push(ms(t.elapsed()));
        }
    }
    println!(
        "EHM-Tracker's keypoint models ({}) on the demo portrait: {:.1} ms ({people} people found, \
         DWPose run on each)",
        dir.display(),
        median(times)
    );
    Ok(())
}

/// Keypoints (ONNX Runtime, its default CPU threads) and the fit (one thread) on the demo portrait.
fn fit_demo_portrait(body: &BodyModel, iterations: usize) -> anyhow::Result<()> {
    let path = std::path::PathBuf::from(guava::DEMO_PORTRAIT);
    let source = SourceImage::load(&path)?;
    let mut models = Landmarkers::load(OnnxRuntime::load()?)?;
    let (mut keypoint_ms, mut embed_ms, mut fit_ms) = (Vec::new(), Vec::new(), Vec::new());
    let mut last = None;
    for i in 0..iterations.min(10) + 1 {
        let t0 = Instant::now();
        let found = models.detect(&source)?;
        let t1 = Instant::now();
        // What fit_detections does, timed in its two parts.
        let embedding = embed_face(body, &mut models.face);
        let t2 = Instant::now();
        let face = found.face.as_ref().zip(embedding.as_ref().ok());
        let input = FitInput {
            keypoints: &found.pose.keypoints,
            face,
            hands: &found.hands,
            irises: &found.irises,
        };
        let (_, mut report) = fit_keypoints(body, &input, source.size)?;
        report.face_skipped = embedding.err().map(|e| e.to_string());
        if i > 0 {
            keypoint_ms.push(ms(t1 - t0));
            embed_ms.push(ms(t2 - t1));
            fit_ms.push(ms(t2.elapsed()));
        }
        last = Some(report);
    }
    let report = last.expect("ran");
    println!(
        "fit of the demo portrait on {}: keypoint models {:.1} ms, face embedding on the body {:.1} ms, fit stages {:.1} ms",
        body.name,
        median(keypoint_ms.clone()),
        median(embed_ms),
        median(fit_ms.clone())
    );
    println!(
        "  ({} body keypoints, {:.1} px RMS; {}; {} irises; {} hands; {} iterations)",
        report.keypoints_used,
        report.rms_px,
        report.face.as_ref().map_or_else(
            || format!(
                "face not fitted: {}",
                report.face_skipped.as_deref().unwrap_or("?")
            ),
            |f| format!("{} face points, {:.1} px RMS", f.points_used, f.rms_px)
        ),
        report.gaze.as_ref().map_or(0, |g| g.observed.len()),
        report.hands.as_ref().map_or(0, |h| h.hands),
        report.iterations
    );
    Ok(())
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}
