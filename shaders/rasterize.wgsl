//! Rasterize: one 16×16 tile per workgroup (3DGS forward.cu:renderCUDA). Each thread shades PIXELS
//! pixels of a column: Gaussians of the tile are fetched front to back in batches of one per thread
//! into workgroup memory, and each loaded Gaussian is reused for all of a thread's pixels. PIXELS = 1
//! is the usual GPU layout; CPU adapters (lavapipe) get 4 up to 16 channels and 2 above
//! (RasterTuning::pixels_per_thread), because there a load from workgroup memory costs far more
//! than the arithmetic.
//! Per pixel: α = min(0.99, o·exp(power)), skipping power > 0 and α < 1/255, stopping before the
//! transmittance would fall under 1e-4. The workgroup leaves once every pixel is done.
//! Pixels go to threads in blocks of 4 × 2·PIXELS, 8 consecutive invocations each (block_pixel):
//! one SIMD row of a CPU adapter shades a compact block, which fewer splats reach than a row; a GPU
//! warp of 32 at PIXELS = 1 still covers 16×2 pixels.
//! With SKIP_MISSED = 1 (CPU adapters) each block walks only the batched Gaussians that reach one
//! of its pixels, from a bit mask per block: there a branch skips no work (a SIMD row runs the
//! loop body for every Gaussian with its lanes masked), but a loop that all of a row's lanes leave
//! is left. The skipped ones would fail the α test at every pixel of the block, so no pixel changes.
//! How a thread reads a batched Gaussian (load_batched, hold_features, feature_word, block_done)
//! comes from rasterize_fetch_loads.wgsl or, on CPU adapters with 8-lane subgroups,
//! rasterize_fetch_shuffles.wgsl, composed before this file.
//! Writes the channels four to a texel, FEATURE_WORDS layers of an rgba32float texture array (layer
//! q holds channels 4q..4q+3, zero past CHANNELS), and accumulated alpha with expected inverse depth
//! as one rg32float texel: a pixel of 32 channels is 9 stores, not 34 (on lavapipe that saved about
//! a tenth of the 32-channel rasterize at 10k Gaussians). Textures, not buffers: a 4096² image of 32
//! channels is 2 GiB, beyond what adapters bind as one storage buffer (128 MiB on lavapipe).
//! llvmpipe counts the iterations of all loops of an invocation (a SIMD row of 8 threads, one
//! block) together and, past 65535, silently leaves every loop (LP_MAX_TGSI_LOOP_ITERATIONS in
//! Mesa's gallivm), so a tile with a long list would leave whole blocks unwritten. The walk
//! takes up to four Gaussians per iteration, and a tile whose walk would run past LOOP_BUDGET
//! (CPU adapters; unbounded on GPUs) stops there and counts itself in STAT_CUT_SHORT: its pixels
//! keep the front-most Gaussians (the list is sorted by depth) and the frame says so.
//! CHANNELS, PIXELS, SKIP_MISSED and LOOP_BUDGET are constants prepended by src/render/shader.rs.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> ranges: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> tile_vals: array<u32>;
@group(0) @binding(3) var<storage, read> projected: array<Projected>;
// Each Gaussian's features as FEATURE_WORDS words of four channels (zero-padded to a multiple of
// four; f32 or f16, shaders/features_*.wgsl): a pixel reads and accumulates a quarter as many
// words as with one float per load.
@group(0) @binding(4) var<storage, read> features: array<FeatureWord>;
const FEATURE_WORDS: u32 = (CHANNELS + 3u) / 4u;
// The background per channel, four to a word like the features (zero-padded).
@group(0) @binding(5) var<storage, read> background: array<vec4<f32>>;
@group(0) @binding(6) var out_features: texture_storage_2d_array<rgba32float, write>;
// One layer: accumulated alpha 1 − T and Σ αT/z.
@group(0) @binding(7) var out_aux: texture_storage_2d_array<rg32float, write>;
@group(0) @binding(8) var<storage, read_write> stats: array<atomic<u32>>;

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

// Per batched Gaussian BATCH_VECS vec4s of workgroup memory: (x, y, 1/depth as bits, id),
// (conic, opacity) and, up to four channels, the features (one load per Gaussian and thread
// instead of one from the storage buffer per pixel). Floats ride as u32 bits, not the id as float
// bits: small ids are subnormal floats, which some GPUs flush to zero.
const PACKED: bool = CHANNELS <= 4u;
const BATCH_VECS: u32 = select(2u, 3u, PACKED);
var<workgroup> batch: array<vec4<u32>, BATCH * BATCH_VECS>;
// With SKIP_MISSED: per batched Gaussian, bit b set if it reaches a pixel of block b; then per
// block, MASK_WORDS words whose bit i is set if batched Gaussian 32·word + i reaches it.
const MASK_WORDS: u32 = BATCH / 32u;
var<workgroup> batch_blocks: array<u32, BATCH>;
var<workgroup> block_masks: array<u32, BLOCKS * MASK_WORDS>;
var<workgroup> num_done: atomic<u32>;
var<workgroup> over_budget: atomic<u32>;
// Bit 0: every pixel done; bit 1: a block ran out of loop budget.
var<workgroup> stop_snapshot: u32;
// Loop iterations a block spends per batch, as counted against LOOP_BUDGET in `main`: the batch
// loop, the mask words' loop and blocks_reached's loop over the blocks (which llvmpipe leaves
// rolled at 16 blocks); and one per walk step. The per-pixel and per-word loops unroll: on
// lavapipe a block stored its pixels after 63.4k iterations counted without them.
const BATCH_LOOPS: u32 = 2u + BLOCKS;

struct Batched {
    xy: vec2<f32>,
    inv_depth: f32,
    id: u32,
    conic_opacity: vec4<f32>,
    packed_features: vec4<f32>,
}

fn batched_from(first: vec4<u32>, second: vec4<u32>, features: vec4<u32>) -> Batched {
    return Batched(
        bitcast<vec2<f32>>(first.xy),
        bitcast<f32>(first.z),
        first.w,
        bitcast<vec4<f32>>(second),
        bitcast<vec4<f32>>(features),
    );
}

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

// Turns the per-Gaussian block bits into per-block masks over the batch: one word per thread
// (a loop, so the SIMD rows past the BLOCKS · MASK_WORDS words leave at once on CPU adapters).
fn build_block_masks(lid: u32) {
    for (var m = lid; m < BLOCKS * MASK_WORDS; m += THREADS) {
        let block = m / MASK_WORDS;
        let first = (m % MASK_WORDS) * 32u;
        var bits = 0u;
        for (var i = 0u; i < 32u; i++) {
            bits |= ((batch_blocks[first + i] >> block) & 1u) << i;
        }
        block_masks[m] = bits;
    }
}

// A thread's pixels: accumulated features, transmittance, Σ αT/z, which are done, how many are not.
struct Pixels {
    acc: array<vec4<f32>, PIXELS * FEATURE_WORDS>,
    t: array<f32, PIXELS>,
    inv_depth: array<f32, PIXELS>,
    done: array<bool, PIXELS>,
    pending: u32,
}

// Blends batched Gaussian j into a thread's pixels, front to back.
fn shade(px: ptr<function, Pixels>, j: u32, lid: u32, lane: u32, origin: vec2<u32>) {
    let g = load_batched(j, lane);
    let co = g.conic_opacity;
    var held: HeldFeatures;
    if !PACKED {
        held = hold_features(g.id, lane);
    }
    for (var k = 0u; k < PIXELS; k++) {
        if (*px).done[k] {
            continue;
        }
        let d = g.xy - vec2<f32>(origin + block_pixel(lid, k));
        let power = -0.5 * (co.x * d.x * d.x + co.z * d.y * d.y) - co.y * d.x * d.y;
        if power > 0.0 {
            continue;
        }
        let alpha = min(0.99, co.w * exp(power));
        if alpha < 1.0 / 255.0 {
            continue;
        }
        let test_t = (*px).t[k] * (1.0 - alpha);
        if test_t < 0.0001 {
            (*px).done[k] = true;
            (*px).pending -= 1u;
            continue;
        }
        let w = alpha * (*px).t[k];
        if PACKED {
            (*px).acc[k] += g.packed_features * w;
        } else {
            for (var q = 0u; q < FEATURE_WORDS; q++) {
                (*px).acc[k * FEATURE_WORDS + q] += feature_word(held, g.id, q) * w;
            }
        }
        (*px).inv_depth[k] += g.inv_depth * w;
        (*px).t[k] = test_t;
    }
}

// The walk's steps: the Gaussian of the lowest set bit of a block's mask word (whose bit 0 is
// batched Gaussian `first`), clearing it; or batched Gaussian j if the batch holds it.
fn shade_next_bit(px: ptr<function, Pixels>, bits: ptr<function, u32>, first: u32, lid: u32, lane: u32, origin: vec2<u32>) {
    if *bits != 0u {
        shade(px, first + firstTrailingBit(*bits), lid, lane, origin);
        *bits &= *bits - 1u;
    }
}

fn shade_below(px: ptr<function, Pixels>, j: u32, n: u32, lid: u32, lane: u32, origin: vec2<u32>) {
    if j < n {
        shade(px, j, lid, lane, origin);
    }
}

@compute @workgroup_size(THREADS)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let origin = wid.xy * TILE_SIZE;
    let range = ranges[wid.y * frame.tiles.x + wid.x];
    let block = lid / BLOCK_THREADS;
    let lane = lid % BLOCK_THREADS;

    var px: Pixels;
    for (var k = 0u; k < PIXELS; k++) {
        let pix = origin + block_pixel(lid, k);
        px.t[k] = 1.0;
        px.done[k] = pix.x >= frame.size.x || pix.y >= frame.size.y;
        if !px.done[k] {
            px.pending += 1u;
        }
    }
    atomicAdd(&num_done, PIXELS - px.pending);

    var start = range.x;
    var loops = 0u;
    loop {
        // Leave together (barriers must stay in uniform control flow): list exhausted, all done
        // or out of loop budget.
        workgroupBarrier();
        if lid == 0u {
            stop_snapshot = u32(atomicLoad(&num_done) == TILE_PIXELS) | (atomicLoad(&over_budget) << 1u);
        }
        let stop = workgroupUniformLoad(&stop_snapshot);
        if stop >= 2u && lid == 0u {
            atomicAdd(&stats[STAT_CUT_SHORT], 1u);
        }
        if start >= range.y || stop != 0u {
            break;
        }
        loops += BATCH_LOOPS;
        let fetch = start + lid;
        var reach = 0u;
        if fetch < range.y {
            let id = tile_vals[fetch];
            let p = projected[id];
            batch[lid * BATCH_VECS] = vec4<u32>(bitcast<vec2<u32>>(p.xy), bitcast<u32>(1.0 / p.depth), id);
            batch[lid * BATCH_VECS + 1u] = bitcast<vec4<u32>>(p.conic_opacity);
            if PACKED {
                batch[lid * BATCH_VECS + 2u] = bitcast<vec4<u32>>(feature_vec(features[id]));
            }
            if SKIP_MISSED == 1u {
                reach = blocks_reached(p.xy, p.conic_opacity, p.q_limit, origin);
            }
        }
        if SKIP_MISSED == 1u {
            batch_blocks[lid] = reach;
            workgroupBarrier();
            build_block_masks(lid);
        }
        workgroupBarrier();
        let n = min(BATCH, range.y - start);
        let pending_before = px.pending;
        // The walk: with SKIP_MISSED the set bits of this block's mask words, else every batched
        // Gaussian; up to four of them per iteration, written out, for llvmpipe's loop budget
        // (above): with one per iteration an avatar drawn within one tile (~60k Gaussians a
        // block) left whole blocks unwritten (test an_avatar_drawn_within_a_tile_matches_the_
        // reference). Checking the block's pixels once per four changes no pixel: a done pixel
        // takes nothing more.
        var mask_word = 0u;
        var bits = 0u;
        var next = 0u;
        loop {
            loops += 1u;
            if loops >= LOOP_BUDGET {
                atomicStore(&over_budget, 1u);
                break;
            }
            if block_done(px.pending, lane) {
                break;
            }
            if SKIP_MISSED == 1u {
                if bits == 0u {
                    if mask_word == MASK_WORDS {
                        break;
                    }
                    bits = block_masks[block * MASK_WORDS + mask_word];
                    mask_word++;
                }
                // A block's lanes share `bits`, so each step is taken by all of them or none.
                let first = (mask_word - 1u) * 32u;
                shade_next_bit(&px, &bits, first, lid, lane, origin);
                shade_next_bit(&px, &bits, first, lid, lane, origin);
                shade_next_bit(&px, &bits, first, lid, lane, origin);
                shade_next_bit(&px, &bits, first, lid, lane, origin);
            } else {
                if next >= n {
                    break;
                }
                shade_below(&px, next, n, lid, lane, origin);
                shade_below(&px, next + 1u, n, lid, lane, origin);
                shade_below(&px, next + 2u, n, lid, lane, origin);
                shade_below(&px, next + 3u, n, lid, lane, origin);
                next += 4u;
            }
        }
        // Counted once per batch, not per finished pixel: num_done is read only at the loop's top.
        if px.pending != pending_before {
            atomicAdd(&num_done, pending_before - px.pending);
        }
        start += BATCH;
    }

    for (var k = 0u; k < PIXELS; k++) {
        let pix = origin + block_pixel(lid, k);
        if pix.x < frame.size.x && pix.y < frame.size.y {
            // Word by word, so each index into `acc` is a constant once the loops unroll. The
            // padding lanes stay zero: their features are zero and so is their background.
            for (var q = 0u; q < FEATURE_WORDS; q++) {
                textureStore(out_features, pix, q, px.acc[k * FEATURE_WORDS + q] + px.t[k] * background[q]);
            }
            textureStore(out_aux, pix, 0u, vec4<f32>(1.0 - px.t[k], px.inv_depth[k], 0.0, 0.0));
        }
    }
}
