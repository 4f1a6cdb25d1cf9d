//! Rasterize: one 16×16 tile per workgroup (3DGS forward.cu:renderCUDA). Each thread shades PIXELS
//! pixels of a column: Gaussians of the tile are fetched front to back in batches of one per thread
//! into workgroup memory, and each loaded Gaussian is reused for all of a thread's pixels. PIXELS = 1
//! is the usual GPU layout; CPU adapters (lavapipe) get 4 for up to four channels, because there a
//! load from workgroup memory costs far more than the arithmetic.
//! Per pixel: α = min(0.99, o·exp(power)), skipping power > 0 and α < 1/255, stopping before the
//! transmittance would fall under 1e-4. The workgroup leaves once every pixel is done.
//! Pixels go to threads in blocks of 4 × 2·PIXELS, 8 consecutive invocations each (block_pixel):
//! one SIMD row of a CPU adapter shades a compact block, which fewer splats reach than a row; a GPU
//! warp of 32 at PIXELS = 1 still covers 16×2 pixels.
//! With SKIP_MISSED = 1 (CPU adapters) each block's threads step over the batched Gaussians that
//! reach none of the block's pixels: there a branch skips no work (a SIMD row runs the loop body
//! for every Gaussian with its lanes masked), but a loop that all of a row's lanes leave is left.
//! The skipped ones would fail the α test at every pixel of the block, so no pixel changes.
//! Writes CHANNELS layers of an r32float texture array (the reference's [C, H, W]) plus accumulated
//! alpha and expected inverse depth as two layers of another. Textures, not buffers: a 4096² image of
//! 32 channels is 2 GiB, beyond what adapters bind as one storage buffer (128 MiB on lavapipe).
//! CHANNELS, PIXELS and SKIP_MISSED are constants prepended by src/render/shader.rs.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> ranges: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> tile_vals: array<u32>;
@group(0) @binding(3) var<storage, read> projected: array<Projected>;
// Each Gaussian's features as FEATURE_WORDS vec4s (zero-padded to a multiple of four channels): a
// pixel reads and accumulates a quarter as many words as with one float per load.
@group(0) @binding(4) var<storage, read> features: array<vec4<f32>>;
const FEATURE_WORDS: u32 = (CHANNELS + 3u) / 4u;
@group(0) @binding(5) var<storage, read> background: array<f32>;
@group(0) @binding(6) var out_features: texture_storage_2d_array<r32float, write>;
// Layer 0: accumulated alpha 1 − T; layer 1: Σ αT/z.
@group(0) @binding(7) var out_aux: texture_storage_2d_array<r32float, write>;

const TILE_PIXELS: u32 = TILE_SIZE * TILE_SIZE;
const THREADS: u32 = TILE_PIXELS / PIXELS;
const BATCH: u32 = THREADS;
// Pixel blocks: BLOCK_THREADS consecutive invocations, 4 across and 2 down, each thread shading
// PIXELS consecutive rows; BLOCKS of them tile the tile.
const BLOCK_THREADS: u32 = 8u;
const BLOCK_W: u32 = 4u;
const BLOCK_H: u32 = 2u * PIXELS;
const BLOCKS_PER_ROW: u32 = TILE_SIZE / BLOCK_W;
const BLOCKS: u32 = THREADS / BLOCK_THREADS;

// Per batched Gaussian, two vec4 loads in the per-pixel loop instead of four (each load from
// workgroup memory is the expensive part on CPU adapters): (x, y, 1/depth as bits, id) and
// (conic, opacity). Floats ride as u32 bits, not the id as float bits: small ids are subnormal
// floats, which some GPUs flush to zero.
var<workgroup> batch_xy_depth_id: array<vec4<u32>, BATCH>;
var<workgroup> batch_conic_opacity: array<vec4<f32>, BATCH>;
// Up to four feature channels ride with the batch: one vec4 load per Gaussian and thread from
// workgroup memory instead of one from the storage buffer.
const PACKED: bool = CHANNELS <= 4u;
var<workgroup> batch_features: array<vec4<f32>, BATCH>;
// With SKIP_MISSED: bit b set if the batched Gaussian reaches a pixel of block b.
var<workgroup> batch_blocks: array<u32, BATCH>;
var<workgroup> num_done: atomic<u32>;
var<workgroup> done_snapshot: u32;

// Pixel k of invocation `lid` in its tile: block lid / 8, blocks row-major over the tile.
fn block_pixel(lid: u32, k: u32) -> vec2<u32> {
    let block = lid / BLOCK_THREADS;
    let i = lid % BLOCK_THREADS;
    return vec2<u32>(
        (block % BLOCKS_PER_ROW) * BLOCK_W + i % BLOCK_W,
        (block / BLOCKS_PER_ROW) * BLOCK_H + (i / BLOCK_W) * PIXELS + k,
    );
}

// The blocks of the tile at `origin` in which a splat can reach α ≥ 1/255 (rect_reached).
fn blocks_reached(xy: vec2<f32>, conic_opacity: vec4<f32>, q_limit: f32, origin: vec2<u32>) -> u32 {
    var bits = 0u;
    for (var b = 0u; b < BLOCKS; b++) {
        let lo = vec2<f32>(origin + block_pixel(b * BLOCK_THREADS, 0u));
        if rect_reached(xy, conic_opacity, q_limit, lo, lo + vec2<f32>(f32(BLOCK_W - 1u), f32(BLOCK_H - 1u))) {
            bits |= 1u << b;
        }
    }
    return bits;
}

@compute @workgroup_size(THREADS)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let origin = wid.xy * TILE_SIZE;
    let range = ranges[wid.y * frame.tiles.x + wid.x];
    let block_bit = 1u << (lid / BLOCK_THREADS);

    var acc: array<vec4<f32>, PIXELS * FEATURE_WORDS>;
    var t: array<f32, PIXELS>;
    var inv_depth: array<f32, PIXELS>;
    var done: array<bool, PIXELS>;
    var pending = 0u;
    for (var k = 0u; k < PIXELS; k++) {
        let pix = origin + block_pixel(lid, k);
        t[k] = 1.0;
        done[k] = pix.x >= frame.size.x || pix.y >= frame.size.y;
        if done[k] {
            atomicAdd(&num_done, 1u);
        } else {
            pending += 1u;
        }
    }

    var start = range.x;
    loop {
        // Leave together (barriers must stay in uniform control flow): list exhausted or all done.
        workgroupBarrier();
        if lid == 0u {
            done_snapshot = atomicLoad(&num_done);
        }
        let all_done = workgroupUniformLoad(&done_snapshot) == TILE_PIXELS;
        if start >= range.y || all_done {
            break;
        }
        let fetch = start + lid;
        if fetch < range.y {
            let id = tile_vals[fetch];
            let p = projected[id];
            batch_xy_depth_id[lid] = vec4<u32>(bitcast<vec2<u32>>(p.xy), bitcast<u32>(1.0 / p.depth), id);
            batch_conic_opacity[lid] = p.conic_opacity;
            if PACKED {
                batch_features[lid] = features[id];
            }
            if SKIP_MISSED == 1u {
                batch_blocks[lid] = blocks_reached(p.xy, p.conic_opacity, p.q_limit, origin);
            }
        }
        workgroupBarrier();
        let n = min(BATCH, range.y - start);
        var j = 0u;
        loop {
            if SKIP_MISSED == 1u {
                while j < n && (batch_blocks[j] & block_bit) == 0u {
                    j++;
                }
            }
            if j >= n || pending == 0u {
                break;
            }
            let packed = batch_xy_depth_id[j];
            let xy = bitcast<vec2<f32>>(packed.xy);
            let co = batch_conic_opacity[j];
            let gaussian_inv_depth = bitcast<f32>(packed.z);
            let base = packed.w * FEATURE_WORDS;
            var packed_features = vec4<f32>();
            if PACKED {
                packed_features = batch_features[j];
            }
            for (var k = 0u; k < PIXELS; k++) {
                if done[k] {
                    continue;
                }
                let d = xy - vec2<f32>(origin + block_pixel(lid, k));
                let power = -0.5 * (co.x * d.x * d.x + co.z * d.y * d.y) - co.y * d.x * d.y;
                if power > 0.0 {
                    continue;
                }
                let alpha = min(0.99, co.w * exp(power));
                if alpha < 1.0 / 255.0 {
                    continue;
                }
                let test_t = t[k] * (1.0 - alpha);
                if test_t < 0.0001 {
                    done[k] = true;
                    pending -= 1u;
                    atomicAdd(&num_done, 1u);
                    continue;
                }
                let w = alpha * t[k];
                if PACKED {
                    acc[k] += packed_features * w;
                } else {
                    for (var q = 0u; q < FEATURE_WORDS; q++) {
                        acc[k * FEATURE_WORDS + q] += features[base + q] * w;
                    }
                }
                inv_depth[k] += gaussian_inv_depth * w;
                t[k] = test_t;
            }

            continuing {
                j++;
            }
        }
        start += BATCH;
    }

    for (var k = 0u; k < PIXELS; k++) {
        let pix = origin + block_pixel(lid, k);
        if pix.x < frame.size.x && pix.y < frame.size.y {
            // Word by word, so each index into `acc` is a constant once the loops unroll.
            for (var q = 0u; q < FEATURE_WORDS; q++) {
                let v = acc[k * FEATURE_WORDS + q];
                for (var i = 0u; i < 4u; i++) {
                    let c = 4u * q + i;
                    if c < CHANNELS {
                        textureStore(out_features, pix, c, vec4<f32>(v[i] + t[k] * background[c], 0.0, 0.0, 0.0));
                    }
                }
            }
            textureStore(out_aux, pix, 0u, vec4<f32>(1.0 - t[k], 0.0, 0.0, 0.0));
            textureStore(out_aux, pix, 1u, vec4<f32>(inv_depth[k], 0.0, 0.0, 0.0));
        }
    }
}
