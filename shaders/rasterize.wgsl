//! Rasterize: one 16×16 tile per workgroup (3DGS forward.cu:renderCUDA). Each thread shades PIXELS
//! pixels of one column (rows `ly + k·ROWS`): Gaussians of the tile are fetched front to back in
//! batches of one per thread into workgroup memory, and each loaded Gaussian is reused for all of a
//! thread's pixels. PIXELS = 1 is the usual one-pixel-per-thread GPU layout; CPU adapters (lavapipe)
//! get more, because there a load from workgroup memory costs far more than the arithmetic.
//! Per pixel: α = min(0.99, o·exp(power)), skipping power > 0 and α < 1/255, stopping before the
//! transmittance would fall under 1e-4. The workgroup leaves once every pixel is done.
//! Writes CHANNELS layers of an r32float texture array (the reference's [C, H, W]) plus accumulated
//! alpha and expected inverse depth as two layers of another. Textures, not buffers: a 4096² image of
//! 32 channels is 2 GiB, beyond what adapters bind as one storage buffer (128 MiB on lavapipe).
//! CHANNELS and PIXELS are constants prepended by src/render/shader.rs.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> ranges: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> tile_vals: array<u32>;
@group(0) @binding(3) var<storage, read> projected: array<Projected>;
// Each Gaussian's features as FEATURE_WORDS vec4s (zero-padded to a multiple of four channels): a
// pixel reads a quarter as many words as with one float per load.
@group(0) @binding(4) var<storage, read> features: array<vec4<f32>>;
const FEATURE_WORDS: u32 = (CHANNELS + 3u) / 4u;
@group(0) @binding(5) var<storage, read> background: array<f32>;
@group(0) @binding(6) var out_features: texture_storage_2d_array<r32float, write>;
// Layer 0: accumulated alpha 1 − T; layer 1: Σ αT/z.
@group(0) @binding(7) var out_aux: texture_storage_2d_array<r32float, write>;

// Rows of threads per tile; each thread covers PIXELS rows spaced ROWS apart.
const ROWS: u32 = TILE_SIZE / PIXELS;
const BATCH: u32 = TILE_SIZE * ROWS;
const TILE_PIXELS: u32 = TILE_SIZE * TILE_SIZE;

// Per batched Gaussian, two vec4 loads in the per-pixel loop instead of four (each load from
// workgroup memory is the expensive part on CPU adapters): (x, y, 1/depth as bits, id) and
// (conic, opacity). Floats ride as u32 bits, not the id as float bits: small ids are subnormal
// floats, which some GPUs flush to zero.
var<workgroup> batch_xy_depth_id: array<vec4<u32>, BATCH>;
var<workgroup> batch_conic_opacity: array<vec4<f32>, BATCH>;
// Up to four feature channels ride with the batch: one vec4 load per Gaussian and thread instead of
// one storage-buffer load per channel for every pixel it shades (the RGB case on CPU adapters).
const PACKED: bool = CHANNELS <= 4u;
var<workgroup> batch_features: array<vec4<f32>, BATCH>;
var<workgroup> num_done: atomic<u32>;
var<workgroup> done_snapshot: u32;

@compute @workgroup_size(TILE_SIZE, ROWS)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let origin = wid.xy * TILE_SIZE;
    let range = ranges[wid.y * frame.tiles.x + wid.x];

    var acc: array<f32, PIXELS * CHANNELS>;
    var t: array<f32, PIXELS>;
    var inv_depth: array<f32, PIXELS>;
    var done: array<bool, PIXELS>;
    var pending = 0u;
    for (var k = 0u; k < PIXELS; k++) {
        let pix = origin + vec2<u32>(local.x, local.y + k * ROWS);
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
        }
        workgroupBarrier();
        let n = min(BATCH, range.y - start);
        for (var j = 0u; j < n && pending > 0u; j++) {
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
                let pixf = vec2<f32>(origin + vec2<u32>(local.x, local.y + k * ROWS));
                let d = xy - pixf;
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
                    for (var c = 0u; c < CHANNELS; c++) {
                        acc[k * CHANNELS + c] += packed_features[c] * w;
                    }
                } else {
                    for (var q = 0u; q < FEATURE_WORDS; q++) {
                        let f = features[base + q];
                        for (var i = 0u; i < 4u; i++) {
                            let c = 4u * q + i;
                            if c < CHANNELS {
                                acc[k * CHANNELS + c] += f[i] * w;
                            }
                        }
                    }
                }
                inv_depth[k] += gaussian_inv_depth * w;
                t[k] = test_t;
            }
        }
        start += BATCH;
    }

    for (var k = 0u; k < PIXELS; k++) {
        let pix = origin + vec2<u32>(local.x, local.y + k * ROWS);
        if pix.x < frame.size.x && pix.y < frame.size.y {
            for (var c = 0u; c < CHANNELS; c++) {
                let v = acc[k * CHANNELS + c] + t[k] * background[c];
                textureStore(out_features, pix, c, vec4<f32>(v, 0.0, 0.0, 0.0));
            }
            textureStore(out_aux, pix, 0u, vec4<f32>(1.0 - t[k], 0.0, 0.0, 0.0));
            textureStore(out_aux, pix, 1u, vec4<f32>(inv_depth[k], 0.0, 0.0, 0.0));
        }
    }
}
