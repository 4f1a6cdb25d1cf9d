//! Error against run time: the avatar drawn with each combination of the knobs that trade one
//! for the other — the UV map's side (reconstructed again for each), which Gaussians (all;
//! template only; UV only; UV Gaussians pruned below an opacity; the coarse stand-in the viewer
//! draws while interacting), the features stored as f32 or f16 (all Gaussians, default UV side),
//! the output side, the refiner on or off — timed pose → pixels and
//! compared with the subject's ground truth; at the smallest side the splatting pass is also
//! checked against the f64 reference on the same Gaussians (the pass's own error).

use anyhow::Result;
use guava::avatar::{Avatar, LocalGaussians, Rig, UvGaussians};
use guava::body::{BodyPose, PosedBody};
use guava::eval::pairs::{self, Pair, View};
use guava::gaussians::GaussianCloud;
use guava::onnx::OnnxRuntime;
use guava::refine::{DEFAULT_REFINER, Refiner};
use guava::render::{FeatureStorage, GpuAvatar, HeadlessRenderer, reference};
use guava::synthetic::{Subject, subject_texture};

use super::{Table, time_ms};
use crate::report::plot::Point;

pub struct Tradeoffs {
    pub table: Table,
    pub points: Vec<Point>,
    pub note: String,
}

/// Which Gaussians are drawn.
const CONTENTS: [&str; 6] = [
    "all",
    "template only",
    "UV only",
    "UV pruned below opacity 0.5",
    "UV pruned below opacity 0.9",
    "coarse stand-in",
];

fn variant(avatar: &Avatar, which: usize) -> Avatar {
    let mut a = avatar.clone();
    match which {
        1 => {
            a.uv = UvGaussians::default();
            a.outside = 0;
        }
        2 => a.template = LocalGaussians::default(),
        3 => prune(&mut a, 0.5),
        4 => prune(&mut a, 0.9),
        5 => a = avatar.preview(),
        _ => {}
    }
    a
}

/// Drops the UV Gaussians fainter than `opacity` (template Gaussians are bound one per vertex
/// and stay); those on parts the photo did not show stay last, counted.
fn prune(avatar: &mut Avatar, opacity: f32) {
    let uv = &avatar.uv;
    let first_outside = uv.local.opacities.len() - avatar.outside;
    let keep: Vec<usize> = (0..uv.local.opacities.len())
        .filter(|&i| uv.local.opacities[i] >= opacity)
        .collect();
    let c = avatar.channels;
    let local = &uv.local;
    let pruned = UvGaussians {
        triangles: keep.iter().map(|&i| uv.triangles[i]).collect(),
        barycentrics: keep.iter().map(|&i| uv.barycentrics[i]).collect(),
        offsets: keep.iter().map(|&i| uv.offsets[i]).collect(),
        local: LocalGaussians {
            rotations: keep.iter().map(|&i| local.rotations[i]).collect(),
            scales: keep.iter().map(|&i| local.scales[i]).collect(),
            opacities: keep.iter().map(|&i| local.opacities[i]).collect(),
            features: keep
                .iter()
                .flat_map(|&i| local.features[i * c..(i + 1) * c].iter().copied())
                .collect(),
        },
    };
    avatar.outside = keep.iter().filter(|&&i| i >= first_outside).count();
    avatar.uv = pruned;
}

/// An avatar of the subject made at one UV map side, and how long making it took.
pub struct Candidate {
    pub uv: u32,
    pub reconstruct_ms: f64,
    pub avatar: Avatar,
}

/// `candidates[0]` is drawn with every choice of Gaussians; the others (other UV sides) with
/// all of them.
pub fn run(
    renderer: &mut HeadlessRenderer,
    subject: &Subject,
    candidates: &[Candidate],
    quick: bool,
) -> Result<Tradeoffs> {
    let body = subject.body;
    let sides: &[u32] = if quick {
        &[128, 256]
    } else {
        &[256, 512, 768, 1024]
    };
    let reps = if quick { 3 } else { 7 };
    let mut refiner = Refiner::load(OnnxRuntime::load()?, std::path::Path::new(DEFAULT_REFINER))?;
    let view = View {
        yaw: 30.0,
        pitch: 0.0,
        zoom: 1.0,
        time: None,
    };
    let pose = BodyPose::rest(body);
    let mut posed = PosedBody::default();
    body.pose(&pose, &mut posed)?;
    let mut table = Table {
        header: vec![
            "uv",
            "reconstruct_ms",
            "gaussians",
            "features",
            "count",
            "side",
            "refiner",
            "frame_ms",
            "refine_ms",
            "total_ms",
            "psnr_db",
            "ssim",
            "iou",
            "vs_f64_max_abs",
            "vs_f64_psnr_db",
            "pareto",
        ],
        rows: Vec::new(),
    };
    let mut points = Vec::new();
    // All Gaussians at the default UV side also with their features stored as f16 (on the
    // same device).
    let mut halves = HeadlessRenderer::with_options(
        renderer.gpu.clone(),
        renderer.pipelines.tuning,
        FeatureStorage::F16,
    );
    let runs = candidates.iter().enumerate().flat_map(|(k, c)| {
        let contents = if k == 0 { CONTENTS.len() } else { 1 };
        let f32_runs = (0..contents).map(move |which| (c, which, FeatureStorage::F32));
        f32_runs.chain((k == 0).then_some((c, 0, FeatureStorage::F16)))
    });
    // Pruning that removes nothing (a default avatar's UV Gaussians are all 0.95 opaque) would
    // only repeat "all": such rows are left out and named in the note.
    let mut removes_nothing = Vec::new();
    for (candidate, which, storage) in runs {
        let renderer = match storage {
            FeatureStorage::F32 => &mut *renderer,
            FeatureStorage::F16 => &mut halves,
        };
        let name = CONTENTS[which];
        let features = format!("{storage:?}").to_lowercase();
        let shown = variant(&candidate.avatar, which);
        if which != 0 && shown.len() == candidate.avatar.len() {
            removes_nothing.push(name);
            continue;
        }
        // The splatting pass's own error at the smallest side: the same Gaussians (rigged once,
        // on the CPU) through the pass and through the f64 reference. (Against the GPU-rigged
        // frame the difference would also hold the rig's 1e-5 float differences, which flip the
        // order of discs at nearly equal depth.)
        let exact = {
            let camera = pairs::camera(body, &view, sides[0]);
            let background = vec![0.0; shown.channels];
            let mut cloud = GaussianCloud::new(shown.channels);
            Rig::default().animate(&shown, &posed, body, &mut cloud)?;
            let (exact, _) = reference::render(&cloud, &camera, &background);
            let (image, _) = renderer.render(&cloud, &camera, &background)?;
            let max_abs = image
                .features
                .iter()
                .zip(&exact.features)
                .chain(image.alpha.iter().zip(&exact.alpha))
                .map(|(a, b)| f64::from((a - b).abs()))
                .fold(0.0, f64::max);
            let mse = image
                .features
                .iter()
                .zip(&exact.features)
                .map(|(a, b)| f64::from(a - b).powi(2))
                .sum::<f64>()
                / image.features.len() as f64;
            Some((max_abs, -10.0 * mse.max(1e-20).log10()))
        };
        let mut gpu = GpuAvatar::new(
            &renderer.gpu.device,
            renderer.pipelines.clone(),
            &shown,
            &body.triangles,
            Some(&body.weld),
        );
        for &side in sides {
            let camera = pairs::camera(body, &view, side);
            let background = vec![0.0; shown.channels];
            let truth = subject.photo(&pose, &camera, subject_texture)?;
            let frame_ms = time_ms(reps, || {
                let _ = renderer.pose_avatar(&mut gpu, &posed);
                renderer.draw(&camera, &background);
            });
            let (image, _) = renderer.render_avatar(&mut gpu, &posed, &camera, &background)?;
            let exact = exact.filter(|_| side == sides[0]);
            let pair = Pair::new(image, &truth);
            for refine in [false, true] {
                let (metrics, refine_ms) = if refine {
                    let mut refined = None;
                    let ms = time_ms(reps, || refined = refiner.refine(&pair.input).ok());
                    let refined = refined.ok_or_else(|| anyhow::anyhow!("the refiner failed"))?;
                    (pair.score(&refined), ms)
                } else {
                    (pair.score(&pair.input), 0.0)
                };
                let m = metrics.ok_or_else(|| anyhow::anyhow!("the subject is out of view"))?;
                let total = frame_ms + refine_ms;
                points.push(Point {
                    label: format!(
                        "UV {}², {name}, {features}, {side}², {}",
                        candidate.uv,
                        if refine { "refined" } else { "raw" }
                    ),
                    time_ms: total,
                    psnr: m.psnr,
                    pareto: false,
                });
                table.rows.push(vec![
                    candidate.uv.to_string(),
                    format!("{:.0}", candidate.reconstruct_ms),
                    name.to_string(),
                    features.clone(),
                    shown.len().to_string(),
                    side.to_string(),
                    if refine { "on" } else { "off" }.into(),
                    format!("{frame_ms:.1}"),
                    format!("{refine_ms:.1}"),
                    format!("{total:.1}"),
                    format!("{:.2}", m.psnr),
                    format!("{:.4}", m.ssim),
                    format!("{:.4}", m.iou),
                    exact.map_or("".into(), |(a, _)| format!("{a:.2e}")),
                    exact.map_or("".into(), |(_, p)| format!("{p:.1}")),
                    String::new(),
                ]);
            }
        }
    }
    // The Pareto front: no other setting is at least as fast and at least as accurate.
    for i in 0..points.len() {
        let p = &points[i];
        let dominated = points.iter().enumerate().any(|(j, q)| {
            j != i
                && q.time_ms <= p.time_ms
                && q.psnr >= p.psnr
                && (q.time_ms < p.time_ms || q.psnr > p.psnr)
        });
        points[i].pareto = !dominated;
        let last = table.rows[i].len() - 1;
        table.rows[i][last] = if dominated { "" } else { "yes" }.into();
    }
    let note = format!(
        "Error: PSNR, SSIM and IoU against the subject's ground truth over its box (as `guava \
         eval` measures). vs_f64: the splatting pass against the f64 reference on the same \
         Gaussians at {}² (max absolute difference over every channel and alpha; PSNR of the \
         channels). uv: the UV map's side the avatar was reconstructed at (reconstruct_ms: how long \
         that took, photo → avatar). features: how the splatting pass stores each Gaussian's \
         channels (f16: half their memory). frame_ms: posing on the GPU and splatting, without \
         reading back; refine_ms: the default refiner through ONNX Runtime on the CPU.{}",
        sides[0],
        match removes_nothing.is_empty() {
            true => String::new(),
            false => format!(
                " Left out, as they remove no Gaussian from this avatar (they would repeat \
                 \"all\"): {}.",
                removes_nothing.join(", ")
            ),
        }
    );
    Ok(Tradeoffs {
        table,
        points,
        note,
    })
}
