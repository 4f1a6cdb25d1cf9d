//! Tile binning. After the depth sort, `gather_counts` lays out each Gaussian's tile count in depth
//! order; scan.wgsl turns that into write offsets; `clamp_pairs` records how many (tile, Gaussian)
//! pairs were needed and how many fit; `emit_keys` writes one pair per covered tile. Emitting in
//! depth order lets the following stable sort by tile alone produce per-tile depth order.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> depth_order: array<u32>;
@group(0) @binding(2) var<storage, read> touched: array<u32>;
@group(0) @binding(3) var<storage, read_write> pair_offsets: array<u32>;
@group(0) @binding(4) var<storage, read> projected: array<Projected>;
@group(0) @binding(5) var<storage, read_write> tile_keys: array<u32>;
@group(0) @binding(6) var<storage, read_write> tile_vals: array<u32>;
// [0] total pairs needed (from the scan), [1] pairs kept = min(needed, capacity).
@group(0) @binding(7) var<storage, read_write> pair_count: array<u32>;
@group(0) @binding(8) var<storage, read_write> stats: array<u32>;

@compute @workgroup_size(256)
fn gather_counts(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = flat_id(wid, nwg, lid, 256u);
    if i < frame.num_gaussians {
        pair_offsets[i] = touched[depth_order[i]];
    }
}

@compute @workgroup_size(1)
fn clamp_pairs() {
    let needed = pair_count[0];
    let kept = min(needed, frame.pair_capacity);
    pair_count[1] = kept;
    stats[STAT_PAIRS_NEEDED] = needed;
    stats[STAT_PAIRS] = kept;
}

@compute @workgroup_size(256)
fn emit_keys(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = flat_id(wid, nwg, lid, 256u);
    if i >= frame.num_gaussians {
        return;
    }
    let id = depth_order[i];
    if touched[id] == 0u {
        return;
    }
    let p = projected[id];
    let rmin = vec2<u32>(p.rect_min & 0xffffu, p.rect_min >> 16u);
    let rmax = vec2<u32>(p.rect_max & 0xffffu, p.rect_max >> 16u);
    var off = pair_offsets[i];
    // The spans preprocess counted (row_span), eight tiles per iteration, written out: a row of
    // 512 tiles is 64 iterations (llvmpipe's loop budget, common.wgsl).
    for (var y = rmin.y; y < rmax.y; y++) {
        let span = row_span(p.xy, p.conic_opacity, p.q_limit, y, rmin.x, rmax.x);
        for (var x = span.x; x < span.y; x += 8u) {
            if !(emit(&off, id, y, x, span.y) && emit(&off, id, y, x + 1u, span.y)
                && emit(&off, id, y, x + 2u, span.y) && emit(&off, id, y, x + 3u, span.y)
                && emit(&off, id, y, x + 4u, span.y) && emit(&off, id, y, x + 5u, span.y)
                && emit(&off, id, y, x + 6u, span.y) && emit(&off, id, y, x + 7u, span.y)) {
                return;
            }
        }
    }
}

// Lists Gaussian `id` in tile (x, y) when x is inside its row's span (< end); false once the
// pair buffer is full (pairs past the capacity are dropped; the host sees needed > kept and
// grows).
fn emit(off: ptr<function, u32>, id: u32, y: u32, x: u32, end: u32) -> bool {
    if x >= end {
        return true;
    }
    if *off >= frame.pair_capacity {
        return false;
    }
    tile_keys[*off] = y * frame.tiles.x + x;
    tile_vals[*off] = id;
    *off += 1u;
    return true;
}
