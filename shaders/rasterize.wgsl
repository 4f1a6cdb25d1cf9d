//! Rasterize: one 16×16 workgroup per tile, one thread per pixel (3DGS forward.cu:renderCUDA).
//! Gaussians of the tile are fetched front to back in batches of 256 into workgroup memory; each
//! pixel blends α = min(0.99, o·exp(power)), skipping power > 0 and α < 1/255, and stops before its
//! transmittance would fall under 1e-4. The workgroup leaves once every pixel is done.
//! Writes CHANNELS layers of an r32float texture array (the reference's [C, H, W]) plus accumulated
//! alpha and expected inverse depth as two layers of another. Textures, not buffers: a 4096² image of
//! 32 channels is 2 GiB, beyond what adapters bind as one storage buffer (128 MiB on lavapipe).
//! CHANNELS is a constant prepended by src/render/shader.rs.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> ranges: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> tile_vals: array<u32>;
@group(0) @binding(3) var<storage, read> projected: array<Projected>;
@group(0) @binding(4) var<storage, read> features: array<f32>;
@group(0) @binding(5) var<storage, read> background: array<f32>;
@group(0) @binding(6) var out_features: texture_storage_2d_array<r32float, write>;
// Layer 0: accumulated alpha 1 − T; layer 1: Σ αT/z.
@group(0) @binding(7) var out_aux: texture_storage_2d_array<r32float, write>;

const BATCH: u32 = 256u;

var<workgroup> batch_id: array<u32, BATCH>;
var<workgroup> batch_xy: array<vec2<f32>, BATCH>;
var<workgroup> batch_conic_opacity: array<vec4<f32>, BATCH>;
var<workgroup> batch_inv_depth: array<f32, BATCH>;
var<workgroup> num_done: atomic<u32>;
var<workgroup> done_snapshot: u32;

@compute @workgroup_size(16, 16)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let pix = wid.xy * TILE_SIZE + local.xy;
    let inside = pix.x < frame.size.x && pix.y < frame.size.y;
    let pixf = vec2<f32>(pix);
    let range = ranges[wid.y * frame.tiles.x + wid.x];

    var acc: array<f32, CHANNELS>;
    var t = 1.0;
    var inv_depth = 0.0;
    var done = !inside;

    if !inside {
        atomicAdd(&num_done, 1u);
    }
    var start = range.x;
    loop {
        // Leave together (barriers must stay in uniform control flow): list exhausted or all done.
        workgroupBarrier();
        if lid == 0u {
            done_snapshot = atomicLoad(&num_done);
        }
        let all_done = workgroupUniformLoad(&done_snapshot) == BATCH;
        if start >= range.y || all_done {
            break;
        }
        let fetch = start + lid;
        if fetch < range.y {
            let id = tile_vals[fetch];
            let p = projected[id];
            batch_id[lid] = id;
            batch_xy[lid] = p.xy;
            batch_conic_opacity[lid] = p.conic_opacity;
            batch_inv_depth[lid] = 1.0 / p.depth;
        }
        workgroupBarrier();
        let n = min(BATCH, range.y - start);
        for (var j = 0u; j < n && !done; j++) {
            let d = batch_xy[j] - pixf;
            let co = batch_conic_opacity[j];
            let power = -0.5 * (co.x * d.x * d.x + co.z * d.y * d.y) - co.y * d.x * d.y;
            if power > 0.0 {
                continue;
            }
            let alpha = min(0.99, co.w * exp(power));
            if alpha < 1.0 / 255.0 {
                continue;
            }
            let test_t = t * (1.0 - alpha);
            if test_t < 0.0001 {
                done = true;
                atomicAdd(&num_done, 1u);
                continue;
            }
            let w = alpha * t;
            let base = batch_id[j] * CHANNELS;
            for (var c = 0u; c < CHANNELS; c++) {
                acc[c] += features[base + c] * w;
            }
            inv_depth += batch_inv_depth[j] * w;
            t = test_t;
        }
        start += BATCH;
    }

    if inside {
        for (var c = 0u; c < CHANNELS; c++) {
            textureStore(out_features, pix, c, vec4<f32>(acc[c] + t * background[c], 0.0, 0.0, 0.0));
        }
        textureStore(out_aux, pix, 0u, vec4<f32>(1.0 - t, 0.0, 0.0, 0.0));
        textureStore(out_aux, pix, 1u, vec4<f32>(inv_depth, 0.0, 0.0, 0.0));
    }
}
