//! Feature storage, f16: four channels per two u32 words (pack2x16float, core WGSL: no f16 shader
//! feature needed), half the memory and bandwidth of f32; values beyond f16's range were stored
//! as ±Inf by the host and are culled as non-finite. Composed like features_f32.wgsl.

alias FeatureWord = vec2<u32>;

fn feature_vec(w: FeatureWord) -> vec4<f32> {
    return vec4<f32>(unpack2x16float(w.x), unpack2x16float(w.y));
}
