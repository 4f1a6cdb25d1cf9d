//! Feature storage, f32: each Gaussian's channels as vec4<f32> words (zero-padded to a multiple of
//! four). Composed before the passes that read features (preprocess, rasterize).

alias FeatureWord = vec4<f32>;

fn feature_vec(w: FeatureWord) -> vec4<f32> {
    return w;
}
