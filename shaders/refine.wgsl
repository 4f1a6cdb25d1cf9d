//! The refiner's network as compute passes on the splatting device (src/refine/wgsl.rs): each
//! entry point is one ONNX operator over f32 tensors stored [C, H, W] (batch 1) in storage
//! buffers. Rust mirror of `Op`: `OpParams` in src/refine/wgsl.rs.

struct Op {
    // Input and output tensors' sizes.
    in_c: u32,
    in_h: u32,
    in_w: u32,
    out_c: u32,
    out_h: u32,
    out_w: u32,
    // Convolution: kernel, stride and the padding before the first row and column.
    kernel_h: u32,
    kernel_w: u32,
    stride_h: u32,
    stride_w: u32,
    pad_top: u32,
    pad_left: u32,
    // What the pass does on top (UNARY_* or, for a convolution, a fused ReLU; for to_rgba, how
    // far it reaches past the splat) and, for copies, the first channel read and written.
    kind: u32,
    src_channel: u32,
    dst_channel: u32,
    // Clip's bounds; Resize's output-over-input scales (y, x).
    lo: f32,
    hi: f32,
    scale_h: f32,
    scale_w: f32,
    _pad: vec4<u32>,
}

const UNARY_NONE: u32 = 0u;
const UNARY_RELU: u32 = 1u;
const UNARY_SIGMOID: u32 = 2u;
const UNARY_CLIP: u32 = 3u;

@group(0) @binding(0) var<uniform> op: Op;
@group(0) @binding(1) var<storage, read> src: array<f32>;
@group(0) @binding(2) var<storage, read_write> dst: array<f32>;
// Convolution: one vec4 of biases per four output channels, then per four output channels the
// weights [in_c][kernel_h][kernel_w] as vec4s (zero past out_c). Add: the second operand.
@group(0) @binding(3) var<storage, read> weights: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> other: array<f32>;

fn apply(kind: u32, v: f32) -> f32 {
    switch kind {
        case UNARY_RELU: { return max(v, 0.0); }
        case UNARY_SIGMOID: { return 1.0 / (1.0 + exp(-v)); }
        case UNARY_CLIP: { return clamp(v, op.lo, op.hi); }
        default: { return v; }
    }
}

// Four output pixels along a row (x) for four output channels (z) per thread: each weight
// vec4 read serves four pixels, each input value read four channels.
const CONV_PIXELS: u32 = 4u;

@compute @workgroup_size(8, 8, 1)
fn conv(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x * CONV_PIXELS;
    let y = id.y;
    if x >= op.out_w || y >= op.out_h {
        return;
    }
    let groups = (op.out_c + 3u) / 4u;
    let taps = op.kernel_h * op.kernel_w;
    let bias = weights[id.z];
    var acc = array<vec4<f32>, CONV_PIXELS>(bias, bias, bias, bias);
    var wi = groups + id.z * op.in_c * taps;
    let plane = op.in_h * op.in_w;
    let x0 = i32(x * op.stride_w) - i32(op.pad_left);
    let y0 = i32(y * op.stride_h) - i32(op.pad_top);
    let step = i32(op.stride_w);
    let w_in = i32(op.in_w);
    for (var c = 0u; c < op.in_c; c++) {
        let base = c * plane;
        for (var ky = 0u; ky < op.kernel_h; ky++) {
            let iy = y0 + i32(ky);
            if iy < 0 || iy >= i32(op.in_h) {
                wi += op.kernel_w;
                continue;
            }
            let row = i32(base + u32(iy) * op.in_w);
            for (var kx = 0u; kx < op.kernel_w; kx++) {
                let w = weights[wi];
                wi++;
                let ix = x0 + i32(kx);
                for (var p = 0u; p < CONV_PIXELS; p++) {
                    let px = ix + i32(p) * step;
                    if px >= 0 && px < w_in {
                        acc[p] += src[row + px] * w;
                    }
                }
            }
        }
    }
    let out_plane = op.out_h * op.out_w;
    for (var p = 0u; p < CONV_PIXELS; p++) {
        if x + p >= op.out_w {
            break;
        }
        for (var k = 0u; k < 4u; k++) {
            let oc = id.z * 4u + k;
            if oc < op.out_c {
                dst[oc * out_plane + y * op.out_w + x + p] = apply(op.kind, acc[p][k]);
            }
        }
    }
}

// ONNX Resize, mode linear, coordinate_transformation_mode half_pixel (PyTorch's bilinear with
// align_corners=False): source coordinates clamped to the image.
@compute @workgroup_size(8, 8, 1)
fn resize(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    let c = id.z;
    if x >= op.out_w || y >= op.out_h || c >= op.out_c {
        return;
    }
    let sx = clamp((f32(x) + 0.5) / op.scale_w - 0.5, 0.0, f32(op.in_w - 1u));
    let sy = clamp((f32(y) + 0.5) / op.scale_h - 0.5, 0.0, f32(op.in_h - 1u));
    let x0 = u32(sx);
    let y0 = u32(sy);
    let x1 = min(x0 + 1u, op.in_w - 1u);
    let y1 = min(y0 + 1u, op.in_h - 1u);
    let fx = sx - f32(x0);
    let fy = sy - f32(y0);
    let base = c * op.in_h * op.in_w;
    let top = mix(src[base + y0 * op.in_w + x0], src[base + y0 * op.in_w + x1], fx);
    let bottom = mix(src[base + y1 * op.in_w + x0], src[base + y1 * op.in_w + x1], fx);
    dst[(c * op.out_h + y) * op.out_w + x] = mix(top, bottom, fy);
}

// out_c channels from `src_channel` on of an image to `dst_channel` on of one of the same size
// (Concat writes each input so, Slice reads its range so).
@compute @workgroup_size(64, 1, 1)
fn copy_channels(@builtin(global_invocation_id) id: vec3<u32>) {
    let plane = op.out_h * op.out_w;
    let i = id.x + id.y * 65535u * 64u;
    if i >= op.out_c * plane {
        return;
    }
    dst[op.dst_channel * plane + i] = src[op.src_channel * plane + i];
}

@compute @workgroup_size(64, 1, 1)
fn unary(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if i >= op.out_c * op.out_h * op.out_w {
        return;
    }
    dst[i] = apply(op.kind, src[i]);
}

@compute @workgroup_size(64, 1, 1)
fn add(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if i >= op.out_c * op.out_h * op.out_w {
        return;
    }
    dst[i] = src[i] + other[i];
}

// The network's input from the splatting pass's output: channel c is splat channel `layers[c]`
// (four to a texel: layer l / 4, lane l % 4), or alpha where its top bit is set (GATHER_ALPHA in
// src/refine/wgsl.rs); the image (in_h × in_w) is padded with zeros to out_h × out_w.
@group(0) @binding(5) var features: texture_2d_array<f32>;
@group(0) @binding(6) var aux: texture_2d_array<f32>;
@group(0) @binding(7) var<storage, read> layers: array<u32>;

const GATHER_ALPHA: u32 = 0x80000000u;

@compute @workgroup_size(8, 8, 1)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = id.x;
    let y = id.y;
    let c = id.z;
    if x >= op.out_w || y >= op.out_h || c >= op.out_c {
        return;
    }
    var v = 0.0;
    if x < op.in_w && y < op.in_h {
        let layer = layers[c];
        let p = vec2<i32>(i32(x), i32(y));
        if (layer & GATHER_ALPHA) != 0u {
            v = textureLoad(aux, p, 0, 0).x;
        } else {
            v = textureLoad(features, p, layer / 4u, 0)[layer % 4u];
        }
    }
    dst[(c * op.out_h + y) * op.out_w + x] = v;
}

// A four-channel output ([4, in_h, in_w]: premultiplied RGB and alpha) as one RGBA texel per
// pixel of the image (out_h × out_w, its top-left corner), for a view to present; held within
// the splat's alpha (`aux` layer 0) dilated by `op.kind` pixels, as `hold_within_splat` in
// src/refine/mod.rs holds the CPU's.
@group(0) @binding(8) var rgba: texture_storage_2d_array<rgba32float, write>;

@compute @workgroup_size(8, 8, 1)
fn to_rgba(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= op.out_w || id.y >= op.out_h {
        return;
    }
    let plane = op.in_h * op.in_w;
    let i = id.y * op.in_w + id.x;
    var v = vec4<f32>(src[i], src[plane + i], src[2u * plane + i], src[3u * plane + i]);
    let r = i32(op.kind);
    let p = vec2<i32>(id.xy);
    let low = max(p - vec2<i32>(r), vec2<i32>(0));
    let high = min(p + vec2<i32>(r), vec2<i32>(i32(op.out_w), i32(op.out_h)) - 1);
    var reach = 0.0;
    for (var y = low.y; y <= high.y; y++) {
        for (var x = low.x; x <= high.x; x++) {
            reach = max(reach, textureLoad(aux, vec2<i32>(x, y), 0, 0).x);
        }
    }
    if v.a > reach {
        v = vec4<f32>(v.rgb * (reach / v.a), reach);
    }
    textureStore(rgba, vec2<u32>(id.x, id.y), 0u, v);
}
