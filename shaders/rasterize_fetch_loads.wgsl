//! How the rasterizer's threads read a batched Gaussian: each thread loads all of it. Composed
//! before rasterize.wgsl when the threads of a block are not one subgroup of 8 lanes (GPUs, and
//! CPU adapters without subgroup shuffles); rasterize_fetch_shuffles.wgsl is the other way.

// The whole Gaussian j from workgroup memory.
fn load_batched(j: u32, lane: u32) -> Batched {
    var features = vec4<u32>();
    if PACKED {
        features = batch[j * BATCH_VECS + 2u];
    }
    return batched_from(batch[j * BATCH_VECS], batch[j * BATCH_VECS + 1u], features);
}

// Nothing held: each feature word is loaded where it is accumulated ([`feature_word`]), so a GPU
// loads it only when some pixel of the warp passes the α test.
alias HeldFeatures = u32;

fn hold_features(id: u32, lane: u32) -> HeldFeatures {
    return 0u;
}

fn feature_word(held: HeldFeatures, id: u32, q: u32) -> vec4<f32> {
    return feature_vec(features[id * FEATURE_WORDS + q]);
}

fn block_done(pending: u32, lane: u32) -> bool {
    return pending == 0u;
}
