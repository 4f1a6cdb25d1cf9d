//! Present: draws the splat output into the viewer's colour target with a full-screen triangle.
//! Reads the channels straight from the textures the rasterizer wrote (no copy): four to a texel,
//! channel c in layer c / 4, lane c % 4; alpha and inverse depth in one texel.
//! Modes: three chosen feature channels as RGB, accumulated alpha, or inverse depth; or a refined
//! picture (premultiplied RGB and alpha in one texel of `features`). The splats are rendered on
//! black; colour is composited over the background here, by alpha.

struct Present {
    size: vec2<u32>,
    mode: u32,
    srgb_target: u32,
    rgb_channels: vec4<u32>,
    inv_depth_range: vec2<f32>,
    _pad: vec2<f32>,
    background: vec4<f32>,
}

const MODE_RGB: u32 = 0u;
const MODE_ALPHA: u32 = 1u;
const MODE_DEPTH: u32 = 2u;
const MODE_REFINED: u32 = 3u;

@group(0) @binding(0) var<uniform> params: Present;
@group(0) @binding(1) var features: texture_2d_array<f32>;
@group(0) @binding(2) var aux: texture_2d_array<f32>;

fn channel(p: vec2<u32>, c: u32) -> f32 {
    return textureLoad(features, p, c / 4u, 0)[c % 4u];
}

@vertex
fn vs_main(@builtin(vertex_index) v: u32) -> FullscreenOut {
    return fullscreen_vertex(v);
}

@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    let p = fullscreen_texel(in.uv, params.size);
    var c: vec3<f32>;
    switch params.mode {
        case MODE_ALPHA: {
            c = vec3<f32>(textureLoad(aux, p, 0u, 0).x);
        }
        case MODE_DEPTH: {
            let r = params.inv_depth_range;
            let d = textureLoad(aux, p, 0u, 0).y;
            c = vec3<f32>(clamp((d - r.x) / max(r.y - r.x, 1e-12), 0.0, 1.0));
        }
        case MODE_REFINED: {
            let v = textureLoad(features, p, 0u, 0);
            c = v.rgb + (1.0 - v.a) * params.background.rgb;
        }
        default: {
            let ch = params.rgb_channels;
            c = vec3<f32>(channel(p, ch.x), channel(p, ch.y), channel(p, ch.z));
            c += (1.0 - textureLoad(aux, p, 0u, 0).x) * params.background.rgb;
        }
    }
    // Feature values are display-referred (like the photos they come from); clamp NaN-free.
    c = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    if params.srgb_target != 0u {
        c = srgb_to_linear(c);
    }
    return vec4<f32>(c, 1.0);
}
