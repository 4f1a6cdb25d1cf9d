//! One 5-bit pass of a stable LSD radix sort of (key, value) pairs, in two dispatches around a
//! prefix scan of the histogram: `histogram` counts each block's digits into hist[digit][block];
//! after scan.wgsl turns that digit-major table into output offsets, `scatter` writes every pair to
//! its place. Each thread owns SORT_ITEMS consecutive pairs and writes them in order, so equal keys
//! keep their order: the property the per-tile depth order relies on (CUB's sort is stable too).
//! The live element count is read from a buffer, so a sort sized on the GPU needs no readback.
//! Work that only some threads have (the live items, the RADIX threads that walk the table) sits
//! behind loop conditions rather than `if`s: CPU adapters (llvmpipe) run an `if` body with the
//! lanes masked off, but leave a loop once all of a SIMD row's lanes have, so idle rows and the
//! blocks past the live count cost next to nothing there. On a GPU the two forms are the same.

const RADIX: u32 = 32u;
// Few threads with many items each: the digit table and the walks over it shrink with the thread
// count (on llvmpipe 32 threads of 64 items sort in about 0.8 of the time of 128 of 16).
const SORT_THREADS: u32 = 32u;
const SORT_ITEMS: u32 = 64u;
const SORT_BLOCK: u32 = SORT_THREADS * SORT_ITEMS;

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
var<workgroup> counts: array<u32, RADIX * SORT_THREADS>;

fn digit_of(key: u32) -> u32 {
    return (key >> pass_params.shift) & (RADIX - 1u);
}

// One byte per digit, four digits to a word, 16 to a vec4: adding one_hot(d) counts digit d with
// no indexing into a per-thread array (which spills to memory on GPUs and is a per-lane loop on
// llvmpipe). A thread counts at most SORT_ITEMS < 256 of a digit.
struct DigitCounts {
    low: vec4<u32>,
    high: vec4<u32>,
}

fn one_hot(d: u32) -> DigitCounts {
    let word = select(vec4<u32>(0u), vec4<u32>(1u << ((d & 3u) * 8u)), vec4<u32>((d >> 2u) & 3u) == vec4<u32>(0u, 1u, 2u, 3u));
    let high = d >= 16u;
    return DigitCounts(select(word, vec4<u32>(0u), high), select(vec4<u32>(0u), word, high));
}

fn add_counts(a: DigitCounts, b: DigitCounts) -> DigitCounts {
    return DigitCounts(a.low + b.low, a.high + b.high);
}

fn byte_of(packed: DigitCounts, d: u32) -> u32 {
    let half = select(packed.low, packed.high, d >= 16u);
    return (half[(d >> 2u) & 3u] >> ((d & 3u) * 8u)) & 0xffu;
}

struct Block {
    // First element of this thread's items, and one past the last live element.
    start: u32,
    n: u32,
    // Threads holding at least one live item: 0 ..< threads.
    threads: u32,
}

fn block_of(block: u32, lid: u32) -> Block {
    let n = count[pass_params.count_index];
    let first = block * SORT_BLOCK;
    let live = select(0u, min(n - first, SORT_BLOCK), n > first);
    return Block(first + lid * SORT_ITEMS, n, (live + SORT_ITEMS - 1u) / SORT_ITEMS);
}

// Counts this thread's digits into the workgroup table (threads past b.threads write nothing and
// are never read).
fn count_digits(b: Block, lid: u32) {
    var packed = DigitCounts();
    for (var k = 0u; k < SORT_ITEMS && b.start + k < b.n; k++) {
        packed = add_counts(packed, one_hot(digit_of(keys_in[b.start + k])));
    }
    for (var d = 0u; d < RADIX && lid < b.threads; d++) {
        counts[d * SORT_THREADS + lid] = byte_of(packed, d);
    }
    workgroupBarrier();
}

@compute @workgroup_size(SORT_THREADS)
fn histogram(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = wid.y * nwg.x + wid.x;
    let b = block_of(block, lid);
    count_digits(b, lid);
    var sum = 0u;
    for (var t = 0u; lid < RADIX && t < b.threads; t++) {
        sum += counts[lid * SORT_THREADS + t];
    }
    if lid < RADIX && block < pass_params.num_blocks {
        hist[lid * pass_params.num_blocks + block] = sum;
    }
}

@compute @workgroup_size(SORT_THREADS)
fn scatter(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = wid.y * nwg.x + wid.x;
    let b = block_of(block, lid);
    count_digits(b, lid);
    // Thread d turns row d into output positions: block offset + earlier threads' counts.
    var running = 0u;
    if lid < RADIX && block < pass_params.num_blocks {
        running = hist[lid * pass_params.num_blocks + block];
    }
    for (var t = 0u; lid < RADIX && t < b.threads; t++) {
        let c = counts[lid * SORT_THREADS + t];
        counts[lid * SORT_THREADS + t] = running;
        running += c;
    }
    workgroupBarrier();
    // Each item goes to its digit's first position for this thread plus the earlier items of
    // the same digit.
    var seen = DigitCounts();
    for (var k = 0u; k < SORT_ITEMS && b.start + k < b.n; k++) {
        let idx = b.start + k;
        let key = keys_in[idx];
        let d = digit_of(key);
        let pos = counts[d * SORT_THREADS + lid] + byte_of(seen, d);
        keys_out[pos] = key;
        vals_out[pos] = vals_in[idx];
        seen = add_counts(seen, one_hot(d));
    }
}
