//! Exclusive prefix sum of u32 in place, in three dispatches (reduce-then-scan):
//! `reduce` sums each block of SCAN_BLOCK values, `scan_sums` scans the block sums in one
//! workgroup and stores the grand total, `scan_blocks` scans each block from its offset.
//! Sums saturate at 0xffffffff: saturating addition is still associative, so a total too big to
//! count (tile pairs of huge Gaussians) reads as "at least u32::MAX" instead of wrapping.
//! Past-the-end items sit behind loop conditions, not `if`s: see radix_sort.wgsl.

// Few threads with many items each, as in radix_sort.wgsl: fewer barrier rounds per block.
const SCAN_THREADS: u32 = 32u;
const SCAN_ITEMS: u32 = 64u;
const SCAN_BLOCK: u32 = SCAN_THREADS * SCAN_ITEMS;

struct ScanParams {
    count: u32,
    num_blocks: u32,
    total_index: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: ScanParams;
@group(0) @binding(1) var<storage, read_write> data: array<u32>;
@group(0) @binding(2) var<storage, read_write> block_sums: array<u32>;
// The grand total lands in totals[params.total_index].
@group(0) @binding(3) var<storage, read_write> totals: array<u32>;

var<workgroup> partial: array<u32, SCAN_THREADS>;

fn sat_add(a: u32, b: u32) -> u32 {
    let s = a + b;
    return select(s, 0xffffffffu, s < a);
}

// Inclusive Hillis–Steele scan of `partial` across the workgroup; returns this thread's value.
fn workgroup_inclusive_scan(lid: u32, value: u32) -> u32 {
    partial[lid] = value;
    workgroupBarrier();
    for (var offset = 1u; offset < SCAN_THREADS; offset = offset << 1u) {
        var v = partial[lid];
        if lid >= offset {
            v = sat_add(v, partial[lid - offset]);
        }
        workgroupBarrier();
        partial[lid] = v;
        workgroupBarrier();
    }
    return partial[lid];
}

fn thread_sum(block: u32, lid: u32) -> u32 {
    var sum = 0u;
    let start = block * SCAN_BLOCK + lid * SCAN_ITEMS;
    for (var k = 0u; k < SCAN_ITEMS && start + k < params.count; k++) {
        sum = sat_add(sum, data[start + k]);
    }
    return sum;
}

@compute @workgroup_size(SCAN_THREADS)
fn reduce(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = wid.y * nwg.x + wid.x;
    let total = workgroup_inclusive_scan(lid, thread_sum(block, lid));
    if lid == SCAN_THREADS - 1u && block < params.num_blocks {
        block_sums[block] = total;
    }
}

@compute @workgroup_size(SCAN_THREADS)
fn scan_sums(@builtin(local_invocation_index) lid: u32) {
    let per_thread = (params.num_blocks + SCAN_THREADS - 1u) / SCAN_THREADS;
    let start = lid * per_thread;
    var sum = 0u;
    for (var k = 0u; k < per_thread && start + k < params.num_blocks; k++) {
        sum = sat_add(sum, block_sums[start + k]);
    }
    let inclusive = workgroup_inclusive_scan(lid, sum);
    var running = 0u;
    if lid > 0u {
        running = partial[lid - 1u];
    }
    for (var k = 0u; k < per_thread && start + k < params.num_blocks; k++) {
        let v = block_sums[start + k];
        block_sums[start + k] = running;
        running = sat_add(running, v);
    }
    if lid == SCAN_THREADS - 1u {
        totals[params.total_index] = inclusive;
    }
}

@compute @workgroup_size(SCAN_THREADS)
fn scan_blocks(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = wid.y * nwg.x + wid.x;
    let sum = thread_sum(block, lid);
    let inclusive = workgroup_inclusive_scan(lid, sum);
    if block >= params.num_blocks {
        return;
    }
    var running = block_sums[block];
    if lid > 0u {
        running = sat_add(running, partial[lid - 1u]);
    }
    let start = block * SCAN_BLOCK + lid * SCAN_ITEMS;
    for (var k = 0u; k < SCAN_ITEMS && start + k < params.count; k++) {
        let v = data[start + k];
        data[start + k] = running;
        running = sat_add(running, v);
    }
}
