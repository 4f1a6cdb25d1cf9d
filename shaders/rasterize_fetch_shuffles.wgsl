//! How the rasterizer's threads read a batched Gaussian on a CPU adapter whose subgroups are the
//! blocks of 8 threads (lavapipe on AVX: 8 lanes, consecutive invocations): the 8 lanes load
//! different words of it and exchange them with subgroup shuffles.
//! Why: llvmpipe turns every load from memory inside control flow into a loop over the lanes, one
//! scalar load each, even when all lanes read the same address; a shuffle at a constant lane is
//! one vector instruction. So a Gaussian's 8 words cost one load per lane instead of 8, and 32
//! feature channels one vec4 per lane instead of 8. Every lane of a block walks the same Gaussians
//! and leaves the walk with the others ([`block_done`]), so all 8 lanes are active at each shuffle.

fn words_of(word: u32, first_lane: u32) -> vec4<u32> {
    return vec4<u32>(
        subgroupShuffle(word, first_lane),
        subgroupShuffle(word, first_lane + 1u),
        subgroupShuffle(word, first_lane + 2u),
        subgroupShuffle(word, first_lane + 3u),
    );
}

// Lane l loads word l of the Gaussian's first two vec4s (and word l % 4 of the third).
fn load_batched(j: u32, lane: u32) -> Batched {
    let word = batch[j * BATCH_VECS + lane / 4u][lane % 4u];
    var features = vec4<u32>();
    if PACKED {
        features = words_of(batch[j * BATCH_VECS + 2u][lane % 4u], 0u);
    }
    return batched_from(words_of(word, 0u), words_of(word, 4u), features);
}

// All feature words, exchanged before the per-pixel tests (a shuffle must not read a lane that a
// branch left): word q is loaded by lane q % 8, in round q / 8 (over 32 channels take two rounds).
const FEATURE_ROUNDS: u32 = (FEATURE_WORDS + BLOCK_THREADS - 1u) / BLOCK_THREADS;
alias HeldFeatures = array<vec4<f32>, FEATURE_WORDS>;

fn hold_features(id: u32, lane: u32) -> HeldFeatures {
    var loaded: array<vec4<f32>, FEATURE_ROUNDS>;
    for (var r = 0u; r < FEATURE_ROUNDS; r++) {
        loaded[r] = feature_vec(features[id * FEATURE_WORDS + min(r * BLOCK_THREADS + lane, FEATURE_WORDS - 1u)]);
    }
    var held: HeldFeatures;
    for (var q = 0u; q < FEATURE_WORDS; q++) {
        held[q] = subgroupShuffle(loaded[q / BLOCK_THREADS], q % BLOCK_THREADS);
    }
    return held;
}

fn feature_word(held: HeldFeatures, id: u32, q: u32) -> vec4<f32> {
    return held[q];
}

// Whether every lane of the block is done: an OR over the 8 lanes in three exchanges (llvmpipe's
// subgroupAll is a loop over the lanes).
fn block_done(pending: u32, lane: u32) -> bool {
    var p = pending;
    p |= subgroupShuffle(p, lane ^ 1u);
    p |= subgroupShuffle(p, lane ^ 2u);
    p |= subgroupShuffle(p, lane ^ 4u);
    return p == 0u;
}
