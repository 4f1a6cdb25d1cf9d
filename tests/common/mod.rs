//! Helpers shared by the integration tests.
#![allow(dead_code)]

use guava::gpu::GpuContext;
use guava::render::{FeatureStorage, HeadlessRenderer, RasterTuning, RenderStats, SplatImage};

/// A renderer on the test machine's adapter (lavapipe in CI). Validation errors panic (wgpu's
/// default uncaptured-error handler), so any invalid GPU use fails the test.
pub fn renderer() -> HeadlessRenderer {
    HeadlessRenderer::new(gpu())
}

pub fn gpu() -> GpuContext {
    GpuContext::headless()
        .expect("a Vulkan adapter (lavapipe: apt-get install mesa-vulkan-drivers)")
}

/// Renderers for the rasterizer's tunings (GPUs' one pixel per thread in lockstep; CPU adapters'
/// 4 pixels per thread up to four channels, 1 above, skipping Gaussians that miss a block of
/// threads, with and without subgroup shuffles), so each is tested whatever the adapter.
pub fn renderers() -> Vec<HeadlessRenderer> {
    renderers_storing(FeatureStorage::F32)
}

/// The same, with features stored as `storage`.
pub fn renderers_storing(storage: FeatureStorage) -> Vec<HeadlessRenderer> {
    cpu_tunings()
        .into_iter()
        .chain([RasterTuning::Lockstep(1)])
        .map(|t| HeadlessRenderer::with_options(gpu(), t, storage))
        .collect()
}

/// The CPU tunings this adapter can run: with shuffles only where its subgroups are 8 lanes
/// (lavapipe on AVX, as in CI); said on stderr where not.
pub fn cpu_tunings() -> Vec<RasterTuning> {
    let gpu = gpu();
    let mut tunings = vec![RasterTuning::Cpu { shuffles: false }];
    if RasterTuning::shuffles_fit(&gpu.adapter.get_info(), gpu.device.features()) {
        tunings.push(RasterTuning::Cpu { shuffles: true });
    } else {
        eprintln!(
            "no 8-lane subgroups on {}: shuffles untested",
            gpu.adapter_label()
        );
    }
    tunings
}

/// The pass's counters against the f64 reference's: every culling count equal; tile pairs no
/// more than the reference's, which lists every tile of a splat's 3σ rectangle where the pass
/// lists only the tiles the splat can reach at α ≥ 1/255 (`row_span` in common.wgsl; the
/// image comparisons check that leaving the others out changes no pixel).
pub fn assert_stats_match(name: &str, gpu: &RenderStats, reference: &RenderStats) {
    let counts = |s: &RenderStats| RenderStats {
        tile_pairs: 0,
        tile_pairs_needed: 0,
        ..*s
    };
    assert_eq!(
        counts(gpu),
        counts(reference),
        "{name}: culling counts must match the reference"
    );
    assert!(
        gpu.tile_pairs <= reference.tile_pairs && gpu.tile_pairs == gpu.tile_pairs_needed,
        "{name}: {} tile pairs, the reference's rectangles give {}",
        gpu.tile_pairs,
        reference.tile_pairs
    );
    println!(
        "{name}: {} of the reference's {} tile pairs",
        gpu.tile_pairs, reference.tile_pairs
    );
}

/// Comparison of two renders over every feature channel, alpha and inverse depth.
#[derive(Debug)]
pub struct Diff {
    pub psnr_db: f64,
    pub max_abs: f64,
    pub max_abs_alpha: f64,
    pub max_rel_inv_depth: f64,
}

pub fn diff(a: &SplatImage, b: &SplatImage) -> Diff {
    assert_eq!(
        (a.width, a.height, a.channels),
        (b.width, b.height, b.channels)
    );
    let mut se = 0.0;
    let mut max_abs: f64 = 0.0;
    for (x, y) in a.features.iter().zip(&b.features) {
        let d = (*x as f64 - *y as f64).abs();
        se += d * d;
        max_abs = max_abs.max(d);
    }
    let mse = se / a.features.len() as f64;
    let max_abs_alpha = a
        .alpha
        .iter()
        .zip(&b.alpha)
        .map(|(x, y)| (x - y).abs() as f64)
        .fold(0.0, f64::max);
    let max_rel_inv_depth = a
        .inv_depth
        .iter()
        .zip(&b.inv_depth)
        .map(|(x, y)| (x - y).abs() as f64 / (y.abs() as f64).max(1e-3))
        .fold(0.0, f64::max);
    Diff {
        psnr_db: if mse == 0.0 {
            f64::INFINITY
        } else {
            10.0 * (1.0 / mse).log10()
        },
        max_abs,
        max_abs_alpha,
        max_rel_inv_depth,
    }
}

pub fn assert_all_finite(image: &SplatImage, what: &str) {
    let bad = image
        .features
        .iter()
        .chain(&image.alpha)
        .chain(&image.inv_depth)
        .filter(|v| !v.is_finite())
        .count();
    assert_eq!(bad, 0, "{what}: {bad} non-finite output values");
}

/// A one-frame tracking of an EHM (SMPL-X) body at rest, seen as the GUAVA-mode tests see it:
/// GUAVA's camera 22 m in front of the body, with `ehm` as its tracked skeleton.
pub fn ehm_rest_tracking(
    ehm: Option<guava::tracking::EhmIdentityRecord>,
) -> guava::tracking::Tracking {
    use guava::tracking::{BodyKind, Frame, TrackedCamera, Tracking};
    let joints = guava::body::SMPLX_JOINTS.map(String::from).to_vec();
    let mut t = Tracking::new(BodyKind::Smplx, 30.0, joints, Vec::new());
    t.identity.ehm = ehm;
    t.frames.push(Frame {
        translation: [0.0; 3],
        rotations: vec![[0.0; 3]; t.joints.len()],
        values: Vec::new(),
        camera: Some(TrackedCamera {
            w2c: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, -1.0, 0.0, 0.2],
                [0.0, 0.0, -1.0, 22.0],
            ],
            invtanfov: 24.0,
            crop: None,
        }),
    });
    t
}

/// An avatar file's bytes with `from` replaced by `to` in its header line (and asserted to be
/// there), the arrays left as they were.
pub fn edit_avatar_header(bytes: &[u8], from: &str, to: &str) -> Vec<u8> {
    let header_end = avatar_header_end(bytes);
    let header = String::from_utf8(bytes[..header_end].to_vec()).expect("utf8");
    assert!(header.contains(from), "the header holds {from}");
    let mut edited = header.replacen(from, to, 1).into_bytes();
    edited.extend_from_slice(&bytes[header_end..]);
    edited
}

/// Where an avatar file's header line ends (the arrays start one byte later).
pub fn avatar_header_end(bytes: &[u8]) -> usize {
    bytes
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == b'\n')
        .nth(1)
        .expect("header")
        .0
}

/// [`guava::synthetic::portrait_placed`] written as a PNG `name` in `dir`.
pub fn portrait_placed(
    dir: &std::path::Path,
    name: &str,
    size: [u32; 2],
    at: [i64; 2],
) -> std::path::PathBuf {
    let path = dir.join(name);
    guava::synthetic::portrait_placed(size, at)
        .expect("portrait")
        .save(&path)
        .expect("save");
    path
}

/// The default reconstruction of a photo file through the pipeline, as `guava reconstruct` runs
/// it: the avatar, the report and the view.
pub fn reconstruct_file(
    pipeline: &mut guava::pipeline::Pipeline,
    body: &guava::body::BodyModel,
    photo: &std::path::Path,
    tracked: guava::pipeline::Tracked,
) -> Result<
    (
        guava::avatar::Avatar,
        guava::pipeline::Report,
        guava::tracking::SourceView,
    ),
    guava::reconstruct::ReconstructError,
> {
    use guava::pipeline::{Mode, Photo};
    let o = pipeline.reconstruct(
        Mode::Default(body),
        Photo::File(photo),
        tracked,
        &mut |_| true,
    )?;
    Ok((o.avatar, o.report, o.view))
}

/// One device for tests that make many small GPU objects (fuzzing), opened once.
pub fn shared_gpu() -> &'static GpuContext {
    static GPU: std::sync::OnceLock<GpuContext> = std::sync::OnceLock::new();
    GPU.get_or_init(gpu)
}
