//! One 4-bit pass of a stable LSD radix sort of (key, value) pairs, in two dispatches around a
//! prefix scan of the histogram: `histogram` counts each block's digits into hist[digit][block];
//! after scan.wgsl turns that digit-major table into output offsets, `scatter` writes every pair to
//! its place. Each thread owns SORT_ITEMS consecutive pairs and writes them in order, so equal keys
//! keep their order: the property the per-tile depth order relies on (CUB's sort is stable too).
//! The live element count is read from a buffer, so a sort sized on the GPU needs no readback.

const RADIX: u32 = 16u;
const SORT_THREADS: u32 = 128u;
const SORT_ITEMS: u32 = 16u;
const SORT_BLOCK: u32 = 2048u;

struct SortPass {
    shift: u32,
    num_blocks: u32,
    // The live element count is count[count_index].
    count_index: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> pass_params: SortPass;
@group(0) @binding(1) var<storage, read> count: array<u32>;
@group(0) @binding(2) var<storage, read> keys_in: array<u32>;
@group(0) @binding(3) var<storage, read> vals_in: array<u32>;
@group(0) @binding(4) var<storage, read_write> keys_out: array<u32>;
@group(0) @binding(5) var<storage, read_write> vals_out: array<u32>;
@group(0) @binding(6) var<storage, read_write> hist: array<u32>;

// counts[digit * SORT_THREADS + thread]
var<workgroup> counts: array<u32, 2048>;

fn digit_of(key: u32) -> u32 {
    return (key >> pass_params.shift) & (RADIX - 1u);
}

// Counts this thread's digits into the workgroup table; returns nothing, leaves counts filled.
fn count_digits(block: u32, lid: u32) {
    var local: array<u32, 16>;
    let n = count[pass_params.count_index];
    let start = block * SORT_BLOCK + lid * SORT_ITEMS;
    for (var k = 0u; k < SORT_ITEMS; k++) {
        if start + k < n {
            let d = digit_of(keys_in[start + k]);
            local[d] += 1u;
        }
    }
    for (var d = 0u; d < RADIX; d++) {
        counts[d * SORT_THREADS + lid] = local[d];
    }
    workgroupBarrier();
}

@compute @workgroup_size(128)
fn histogram(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = wid.y * nwg.x + wid.x;
    count_digits(block, lid);
    if lid < RADIX && block < pass_params.num_blocks {
        var sum = 0u;
        for (var t = 0u; t < SORT_THREADS; t++) {
            sum += counts[lid * SORT_THREADS + t];
        }
        hist[lid * pass_params.num_blocks + block] = sum;
    }
}

@compute @workgroup_size(128)
fn scatter(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = wid.y * nwg.x + wid.x;
    count_digits(block, lid);
    // Thread d turns row d into output positions: block offset + earlier threads' counts.
    if lid < RADIX && block < pass_params.num_blocks {
        var running = hist[lid * pass_params.num_blocks + block];
        for (var t = 0u; t < SORT_THREADS; t++) {
            let c = counts[lid * SORT_THREADS + t];
            counts[lid * SORT_THREADS + t] = running;
            running += c;
        }
    }
    workgroupBarrier();
    var pos: array<u32, 16>;
    for (var d = 0u; d < RADIX; d++) {
        pos[d] = counts[d * SORT_THREADS + lid];
    }
    let n = count[pass_params.count_index];
    let start = block * SORT_BLOCK + lid * SORT_ITEMS;
    for (var k = 0u; k < SORT_ITEMS; k++) {
        let idx = start + k;
        if idx < n {
            let key = keys_in[idx];
            let d = digit_of(key);
            keys_out[pos[d]] = key;
            vals_out[pos[d]] = vals_in[idx];
            pos[d] += 1u;
        }
    }
}
