//! Definitions shared by the splatting passes. src/render/shader.rs prepends this file (and any
//! `const` overrides such as CHANNELS) to each pass, so layouts are written once.
//! Rust mirrors: `FrameUniform` and `GpuGaussian`/`Projected` in src/render/layout.rs.

const TILE_SIZE: u32 = 16u;
// Depth keys of culled Gaussians: above every finite positive float, so they sort last.
const CULLED_KEY: u32 = 0xffffffffu;

// Indices into the stats buffer (RenderStats in src/render/mod.rs).
const STAT_NONFINITE: u32 = 0u;
const STAT_NEAR: u32 = 1u;
const STAT_TRANSPARENT: u32 = 2u;
const STAT_DEGENERATE: u32 = 3u;
const STAT_OUTSIDE: u32 = 4u;
const STAT_VISIBLE: u32 = 5u;
const STAT_PAIRS_NEEDED: u32 = 6u;
const STAT_PAIRS: u32 = 7u;
const STAT_CUT_SHORT: u32 = 8u;

struct Frame {
    view_from_world: mat4x4<f32>,
    focal: vec2<f32>,
    // Principal point in centre-at-integer pixels (cx − 0.5, cy − 0.5).
    principal: vec2<f32>,
    // EWA Jacobian clamp on x/z and y/z: (x_neg, x_pos, y_neg, y_pos).
    ewa_lim: vec4<f32>,
    size: vec2<u32>,
    tiles: vec2<u32>,
    near: f32,
    num_gaussians: u32,
    pair_capacity: u32,
    channels: u32,
    // LowPass (src/gaussians/mod.rs): 0 dilated as 3DGS, 1 compensated as Mip-Splatting.
    low_pass: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Gaussian {
    pos: vec3<f32>,
    opacity: f32,
    // (w, x, y, z), not renormalised (as forward.cu:computeCov3D).
    rot: vec4<f32>,
    scale: vec3<f32>,
    _pad: f32,
}

struct Projected {
    conic_opacity: vec4<f32>,
    xy: vec2<f32>,
    depth: f32,
    // Tile rectangle [min, max), x in the low 16 bits, y in the high 16.
    rect_min: u32,
    rect_max: u32,
    // reach_limit(opacity), found once in the preprocess for every reach test of this splat.
    q_limit: f32,
    _pad1: u32,
    _pad2: u32,
}

// Bit test, not `x != x`: shader compilers may assume floats are finite and fold that away.
fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn all_finite(v: vec4<f32>) -> bool {
    return all((bitcast<vec4<u32>>(v) & vec4<u32>(0x7f800000u)) != vec4<u32>(0x7f800000u));
}

// Dispatches larger than 65535 workgroups are split over y; this recovers the flat index.
fn flat_id(wid: vec3<u32>, nwg: vec3<u32>, lid: u32, wg_size: u32) -> u32 {
    return (wid.y * nwg.x + wid.x) * wg_size + lid;
}

// α = o·exp(−q/2) with q = A dx² + 2B dx dy + C dy², so a pixel is reached (α ≥ 1/255) iff its q is
// at most 2 ln(255 o). A 1e-3 margin on q (α 0.05 % under the threshold) covers the rasterizer's
// f32 rounding, so leaving a pixel out never changes it.
fn reach_limit(opacity: f32) -> f32 {
    return 2.0 * log(255.0 * opacity) + 1e-3;
}

// Pixels of slack on every side of a row's span (row_span) for f32 rounding: a tile more, rarely.
const SPAN_SLACK: f32 = 0.015625;

// The tiles [x, y) of tile row `ty`, within columns [first, end), in which a splat at `xy`
// (pixel coordinates) with conic (A, B, C) and reach_limit `q_limit` can reach α ≥ 1/255: those
// whose pixel positions meet the ellipse q ≤ q_limit, as rect_reached decides per rectangle, for
// a whole row at once. The ellipse's points in the row's band of y span one interval of x: at a
// fixed dy = v its dx = u runs over (−Bv ± √(AL − det·v²)) / A, whose ends are concave and convex
// in v, so the band's extremes are at the ellipse's own (u = ±√(CL/det), v = ∓Bu/C) clamped into
// the band. Preprocess counts a splat's tiles and tile keys lists them row by row with it: one
// loop iteration per row, not per tile, because llvmpipe leaves every loop of an invocation after
// 65,535 iterations in all (see rasterize.wgsl), and a splat filling a 4096² image spans 65,536
// tiles (walked tile by tile it got 65,025: test a_splat_filling_the_image_is_in_every_tile).
fn row_span(xy: vec2<f32>, conic_opacity: vec4<f32>, q_limit: f32, ty: u32, first: u32, end: u32) -> vec2<u32> {
    let a = conic_opacity.x;
    let b = conic_opacity.y;
    let c = conic_opacity.z;
    // A needle's a·c and b² nearly cancel: the product's rounding error taken back (Kahan).
    let bb = b * b;
    let det = fma(a, c, -bb) - fma(b, b, -bb);
    let none = vec2<u32>(first, first);
    if !(det > 0.0 && a > 0.0 && c > 0.0 && q_limit > 0.0) {
        return none;
    }
    // dy over the row's pixel positions, within the ellipse's own extent.
    let y_lo = f32(ty * TILE_SIZE);
    let v_max = sqrt(a * q_limit / det);
    let v0 = max(xy.y - (y_lo + f32(TILE_SIZE - 1u)) - SPAN_SLACK, -v_max);
    let v1 = min(xy.y - y_lo + SPAN_SLACK, v_max);
    if v0 > v1 {
        return none;
    }
    let u_star = sqrt(c * q_limit / det);
    let v_hi = clamp(-b * u_star / c, v0, v1);
    let v_lo = clamp(b * u_star / c, v0, v1);
    let u_hi = (-b * v_hi + sqrt(max(a * q_limit - det * v_hi * v_hi, 0.0))) / a;
    let u_lo = (-b * v_lo - sqrt(max(a * q_limit - det * v_lo * v_lo, 0.0))) / a;
    // Pixel x = xy.x − u.
    let x_lo = xy.x - u_hi - SPAN_SLACK;
    let x_hi = xy.x - u_lo + SPAN_SLACK;
    // Tiles whose positions [16t, 16t + 15] meet [x_lo, x_hi]; i32() saturates.
    let t0 = clamp(i32(ceil((x_lo - f32(TILE_SIZE - 1u)) / f32(TILE_SIZE))), i32(first), i32(end));
    let t1 = clamp(i32(floor(x_hi / f32(TILE_SIZE))) + 1, t0, i32(end));
    return vec2<u32>(u32(t0), u32(t1));
}

// Whether a splat at `xy` with conic (A, B, C) and reach_limit `q_limit` can reach α ≥ 1/255 at
// a pixel with position in [lo, hi]: the least q over the rectangle of positions (its centre
// inside → 0, else on one of the four edges, each a clamped 1D minimum) is at most that over its
// pixels.
fn rect_reached(xy: vec2<f32>, conic_opacity: vec4<f32>, q_limit: f32, lo: vec2<f32>, hi: vec2<f32>) -> bool {
    if all(xy >= lo) && all(xy <= hi) {
        return true;
    }
    let a = conic_opacity.x;
    let b = conic_opacity.y;
    let c = conic_opacity.z;
    // d = xy − pixel, as the rasterizer takes it: d spans [xy − hi, xy − lo] on each axis.
    let d_lo = xy - hi;
    let d_hi = xy - lo;
    var q_min = 3.4e38;
    for (var e = 0u; e < 2u; e++) {
        // Edges at fixed dx (the left and right columns) and at fixed dy.
        let dx = select(d_lo.x, d_hi.x, e == 1u);
        let dy_star = clamp(-b * dx / c, d_lo.y, d_hi.y);
        q_min = min(q_min, a * dx * dx + 2.0 * b * dx * dy_star + c * dy_star * dy_star);
        let dy = select(d_lo.y, d_hi.y, e == 1u);
        let dx_star = clamp(-b * dy / a, d_lo.x, d_hi.x);
        q_min = min(q_min, a * dx_star * dx_star + 2.0 * b * dx_star * dy + c * dy * dy);
    }
    return q_min <= q_limit;
}

// Display-referred (sRGB-encoded) colour to linear, for writing into an sRGB render target.
fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

// Full-screen triangle for passes that draw an image one texel per pixel: clip position and
// uv in [0, 1] (y down) for vertex 0, 1, 2.
struct FullscreenOut {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
}

fn fullscreen_vertex(v: u32) -> FullscreenOut {
    let uv = vec2<f32>(f32((v << 1u) & 2u), f32(v & 2u));
    var out: FullscreenOut;
    out.position = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    return out;
}

// The texel under a full-screen uv, clamped into a `size` image.
fn fullscreen_texel(uv: vec2<f32>, size: vec2<u32>) -> vec2<u32> {
    return min(vec2<u32>(uv * vec2<f32>(size)), size - 1u);
}
