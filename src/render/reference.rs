//! The slow, exact reference: the forward pass of the 3DGS rasterizer GUAVA uses
//! (`submodules/diff-gaussian-rasterization-32/cuda_rasterizer/forward.cu`, antialiasing off) in
//! f64 with per-pixel loops. The wgpu pass is tested against it; it is written to be read, not fast.
//!
//! Steps, as in the reference: near cull (`z ≤ near`), 3D covariance `R·S²·Rᵀ` from the unnormalised
//! quaternion, EWA projection with the Jacobian's x/z, y/z clamped to 1.3·tan(fov/2), +0.3 px² on the
//! 2D covariance diagonal, radius `ceil(3·sqrt(λmax))` with λ's discriminant floored at 0.1, 16×16
//! tile rectangles, per-tile order by (depth, index), then per pixel front to back:
//! `α = min(0.99, o·exp(power))`, skip if `power > 0` or `α < 1/255`, stop before `T` would fall
//! under 1e-4; output `Σ cᵢαᵢTᵢ + T·bg`, accumulated alpha `1 − T`, and inverse depth `Σ αᵢTᵢ/zᵢ`.
//!
//! Two deliberate differences, both below f32 resolution: the mean is projected as `f·x/z` (the
//! reference divides by `w + 1e-7`), and Gaussians with opacity < 1/255 or non-finite attributes
//! are dropped up front (the first can never pass the alpha test; the second the reference would
//! draw as NaN).

use super::{RenderStats, SplatImage, TILE_SIZE};
use crate::camera::Camera;
use crate::gaussians::GaussianCloud;
use crate::gaussians::LowPass;
use glam::{DMat3, DVec3, DVec4};

pub const ALPHA_MIN: f64 = 1.0 / 255.0;
pub const ALPHA_MAX: f64 = 0.99;
pub const TRANSMITTANCE_MIN: f64 = 1e-4;
pub const LOW_PASS: f64 = 0.3;

/// One Gaussian after projection: what the per-pixel loop needs.
#[derive(Clone, Copy, Debug)]
pub struct Splat {
    pub index: usize,
    pub xy: [f64; 2],
    pub conic: [f64; 3],
    pub opacity: f64,
    pub depth: f64,
    /// Tile rectangle [min, max) in tiles.
    pub rect: [u32; 4],
}

/// Why a Gaussian is not drawn (counted in [`RenderStats`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Culled {
    NonFinite,
    Near,
    Transparent,
    Degenerate,
    Outside,
}

pub fn rotation_from_quaternion(q: [f32; 4]) -> DMat3 {
    let [r, x, y, z] = q.map(f64::from);
    DMat3::from_cols(
        DVec3::new(
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y + r * z),
            2.0 * (x * z - r * y),
        ),
        DVec3::new(
            2.0 * (x * y - r * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z + r * x),
        ),
        DVec3::new(
            2.0 * (x * z + r * y),
            2.0 * (y * z - r * x),
            1.0 - 2.0 * (x * x + y * y),
        ),
    )
}

pub fn project(cloud: &GaussianCloud, i: usize, camera: &Camera) -> Result<Splat, Culled> {
    let finite = cloud.positions[i].iter().all(|v| v.is_finite())
        && cloud.rotations[i].iter().all(|v| v.is_finite())
        && cloud.scales[i].iter().all(|v| v.is_finite())
        && cloud.opacities[i].is_finite()
        && cloud.features_of(i).iter().all(|v| v.is_finite());
    if !finite {
        return Err(Culled::NonFinite);
    }
    let view = camera.view_from_world.as_dmat4();
    let t = view * DVec4::from((DVec3::from(cloud.positions[i].map(f64::from)), 1.0));
    if t.z <= camera.near as f64 {
        return Err(Culled::Near);
    }
    let opacity = cloud.opacities[i] as f64;
    if opacity < ALPHA_MIN {
        return Err(Culled::Transparent);
    }

    let rot = rotation_from_quaternion(cloud.rotations[i]);
    let s2 = DVec3::from(cloud.scales[i].map(|s| (s as f64) * (s as f64)));
    let cov3 = rot * DMat3::from_diagonal(s2) * rot.transpose();

    let (fx, fy) = (camera.fx as f64, camera.fy as f64);
    let lim = camera.ewa_limits().map(f64::from);
    let tx = (t.x / t.z).clamp(-lim[0], lim[1]) * t.z;
    let ty = (t.y / t.z).clamp(-lim[2], lim[3]) * t.z;
    // J (rows: d(pixel x, pixel y)/d(view xyz)); third row zero.
    let j = DMat3::from_cols(
        DVec3::new(fx / t.z, 0.0, 0.0),
        DVec3::new(0.0, fy / t.z, 0.0),
        DVec3::new(-fx * tx / (t.z * t.z), -fy * ty / (t.z * t.z), 0.0),
    );
    let w = glam::DMat3::from_mat4(view);
    let jw = j * w;
    let cov2 = jw * cov3 * jw.transpose();
    let (a, b, c) = (
        cov2.x_axis.x + LOW_PASS,
        cov2.y_axis.x,
        cov2.y_axis.y + LOW_PASS,
    );
    let det = a * c - b * b;
    if det == 0.0 || !det.is_finite() {
        return Err(Culled::Degenerate);
    }
    // Mip-Splatting's 2D filter: det cov2 = |r₀ × r₁|² for the rows of J·W·R·S.
    let opacity = match cloud.low_pass {
        LowPass::Dilated => opacity,
        LowPass::Compensated => {
            let p = jw * rot * DMat3::from_diagonal(DVec3::from(cloud.scales[i].map(f64::from)));
            let across = p.row(0).cross(p.row(1));
            opacity * (across.length_squared() / det).sqrt()
        }
    };
    let conic = [c / det, -b / det, a / det];
    let mid = 0.5 * (a + c);
    let disc = (mid * mid - det).max(0.1).sqrt();
    let radius = (3.0 * (mid + disc).max(mid - disc).sqrt()).ceil();
    let xy = [
        fx * t.x / t.z + camera.cx as f64 - 0.5,
        fy * t.y / t.z + camera.cy as f64 - 0.5,
    ];
    if !(radius.is_finite() && xy[0].is_finite() && xy[1].is_finite()) {
        return Err(Culled::Degenerate);
    }
    let (tiles_x, tiles_y) = super::tile_grid(camera);
    let tile = TILE_SIZE as f64;
    // C casts truncate toward zero; clamping to the grid makes that equal to floor here.
    let bound = |v: f64, n: u32| (v / tile).trunc().clamp(0.0, n as f64) as u32;
    let rect = [
        bound(xy[0] - radius, tiles_x),
        bound(xy[1] - radius, tiles_y),
        bound(xy[0] + radius + tile - 1.0, tiles_x),
        bound(xy[1] + radius + tile - 1.0, tiles_y),
    ];
    if rect[0] == rect[2] || rect[1] == rect[3] {
        return Err(Culled::Outside);
    }
    Ok(Splat {
        index: i,
        xy,
        conic,
        opacity,
        depth: t.z,
        rect,
    })
}

/// Renders `cloud` exactly as the reference forward pass does; `background` has one value per channel.
pub fn render(
    cloud: &GaussianCloud,
    camera: &Camera,
    background: &[f32],
) -> (SplatImage, RenderStats) {
    assert_eq!(
        background.len(),
        cloud.channels,
        "one background value per channel"
    );
    let mut stats = RenderStats {
        input: cloud.len() as u64,
        ..Default::default()
    };
    let mut splats = Vec::new();
    for i in 0..cloud.len() {
        match project(cloud, i, camera) {
            Ok(s) => splats.push(s),
            Err(why) => stats.count_culled(why),
        }
    }
    stats.visible = splats.len() as u64;
    // Per-tile lists in (depth, index) order: the stable sort of the reference's 64-bit keys,
    // whose depth half is the f32 view depth — so depths that round to the same f32 are ties
    // broken by index, as there (sorting by the f64 depth ordered the discs of an avatar's
    // sheets differently and put 0.29 of colour between the passes at some pixels).
    splats.sort_by(|a, b| {
        (a.depth as f32)
            .total_cmp(&(b.depth as f32))
            .then(a.index.cmp(&b.index))
    });
    let (tiles_x, tiles_y) = super::tile_grid(camera);
    let mut tile_lists: Vec<Vec<usize>> = vec![Vec::new(); (tiles_x * tiles_y) as usize];
    for (k, s) in splats.iter().enumerate() {
        for ty in s.rect[1]..s.rect[3] {
            for tx in s.rect[0]..s.rect[2] {
                tile_lists[(ty * tiles_x + tx) as usize].push(k);
                stats.tile_pairs += 1;
            }
        }
    }
    stats.tile_pairs_needed = stats.tile_pairs;

    let (w, h, ch) = (
        camera.width as usize,
        camera.height as usize,
        cloud.channels,
    );
    let mut image = SplatImage::new(camera.width, camera.height, ch);
    // Rows of pixels are independent: split them over threads.
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let rows_per = h.div_ceil(threads).max(1);
    let mut rows: Vec<(usize, Vec<f64>)> = Vec::new();
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..h)
            .step_by(rows_per)
            .map(|y0| {
                let (splats, tile_lists) = (&splats, &tile_lists);
                scope.spawn(move || {
                    let y1 = (y0 + rows_per).min(h);
                    let mut out = vec![0.0; (y1 - y0) * w * (ch + 2)];
                    for y in y0..y1 {
                        for x in 0..w {
                            let tile = (y / TILE_SIZE as usize) * tiles_x as usize
                                + x / TILE_SIZE as usize;
                            let px =
                                shade_pixel(x, y, &tile_lists[tile], splats, cloud, background);
                            let o = ((y - y0) * w + x) * (ch + 2);
                            out[o..o + ch + 2].copy_from_slice(&px);
                        }
                    }
                    (y0, out)
                })
            })
            .collect();
        rows = handles
            .into_iter()
            .map(|h| h.join().expect("reference row thread"))
            .collect();
    });
    for (y0, out) in rows {
        for (k, px) in out.chunks_exact(ch + 2).enumerate() {
            let p = y0 * w + k;
            for (c, v) in px[..ch].iter().enumerate() {
                image.features[c * w * h + p] = *v as f32;
            }
            image.alpha[p] = px[ch] as f32;
            image.inv_depth[p] = px[ch + 1] as f32;
        }
    }
    (image, stats)
}

/// Front-to-back blending of one pixel; returns [features…, alpha, inverse depth].
fn shade_pixel(
    x: usize,
    y: usize,
    list: &[usize],
    splats: &[Splat],
    cloud: &GaussianCloud,
    background: &[f32],
) -> Vec<f64> {
    let ch = cloud.channels;
    let mut acc = vec![0.0; ch + 2];
    let mut t = 1.0;
    for &k in list {
        let s = &splats[k];
        let d = [s.xy[0] - x as f64, s.xy[1] - y as f64];
        let power =
            -0.5 * (s.conic[0] * d[0] * d[0] + s.conic[2] * d[1] * d[1]) - s.conic[1] * d[0] * d[1];
        if power > 0.0 {
            continue;
        }
        let alpha = (s.opacity * power.exp()).min(ALPHA_MAX);
        if alpha < ALPHA_MIN {
            continue;
        }
        let test_t = t * (1.0 - alpha);
        if test_t < TRANSMITTANCE_MIN {
            break;
        }
        for (c, f) in cloud.features_of(s.index).iter().enumerate() {
            acc[c] += *f as f64 * alpha * t;
        }
        acc[ch + 1] += alpha * t / s.depth;
        t = test_t;
    }
    for c in 0..ch {
        acc[c] += t * background[c] as f64;
    }
    acc[ch] = 1.0 - t;
    acc
}
