//! Preprocess: one thread per Gaussian. Culls (non-finite, near plane z ≤ near, opacity < 1/255,
//! degenerate, off-screen), projects the mean, builds the 3D covariance R·S²·Rᵀ and its EWA
//! projection (Zwicker et al. 2001; 3DGS forward.cu:preprocessCUDA/computeCov2D), adds the 0.3 px²
//! low-pass, and writes the conic, the 3σ tile rectangle, the depth sort key and the tile count.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> gaussians: array<Gaussian>;
// Each Gaussian's features are zero-padded to a multiple of four channels (see the rasterizer),
// stored as f32 or f16 (shaders/features_*.wgsl).
@group(0) @binding(2) var<storage, read> features: array<FeatureWord>;
@group(0) @binding(3) var<storage, read_write> projected: array<Projected>;
@group(0) @binding(4) var<storage, read_write> depth_keys: array<u32>;
@group(0) @binding(5) var<storage, read_write> depth_order: array<u32>;
@group(0) @binding(6) var<storage, read_write> touched: array<u32>;
@group(0) @binding(7) var<storage, read_write> stats: array<atomic<u32>>;

fn rotation(q: vec4<f32>) -> mat3x3<f32> {
    let r = q.x; let x = q.y; let y = q.z; let z = q.w;
    return mat3x3<f32>(
        vec3<f32>(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + r * z), 2.0 * (x * z - r * y)),
        vec3<f32>(2.0 * (x * y - r * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + r * x)),
        vec3<f32>(2.0 * (x * z + r * y), 2.0 * (y * z - r * x), 1.0 - 2.0 * (x * x + y * y)),
    );
}

fn tile_bound(v: f32, n: u32) -> u32 {
    // i32() saturates in WGSL, so huge radii clamp instead of wrapping; C truncation toward zero.
    return u32(clamp(i32(v / f32(TILE_SIZE)), 0, i32(n)));
}

@compute @workgroup_size(256)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = flat_id(wid, nwg, lid, 256u);
    if i >= frame.num_gaussians {
        return;
    }
    depth_order[i] = i;
    depth_keys[i] = CULLED_KEY;
    touched[i] = 0u;

    let g = gaussians[i];
    var finite = all_finite(vec4<f32>(g.pos, g.opacity)) && all_finite(g.rot)
        && all_finite(vec4<f32>(g.scale, 0.0));
    // Four channels per load; the loop ends at the first non-finite word (a loop, not an `if`,
    // lets a CPU adapter's SIMD row stop early, see radix_sort.wgsl).
    let words = (frame.channels + 3u) / 4u;
    for (var q = 0u; q < words && finite; q++) {
        finite = all_finite(feature_vec(features[i * words + q]));
    }
    if !finite {
        atomicAdd(&stats[STAT_NONFINITE], 1u);
        return;
    }

    let t = (frame.view_from_world * vec4<f32>(g.pos, 1.0)).xyz;
    if t.z <= frame.near {
        atomicAdd(&stats[STAT_NEAR], 1u);
        return;
    }
    // alpha = min(0.99, o·exp(power)) ≤ o, so these can never pass the 1/255 test.
    if g.opacity < 1.0 / 255.0 {
        atomicAdd(&stats[STAT_TRANSPARENT], 1u);
        return;
    }

    let m = rotation(g.rot) * mat3x3<f32>(
        vec3<f32>(g.scale.x, 0.0, 0.0), vec3<f32>(0.0, g.scale.y, 0.0), vec3<f32>(0.0, 0.0, g.scale.z));
    let cov3 = m * transpose(m);

    let lim = frame.ewa_lim;
    let tx = clamp(t.x / t.z, -lim.x, lim.y) * t.z;
    let ty = clamp(t.y / t.z, -lim.z, lim.w) * t.z;
    let fx = frame.focal.x;
    let fy = frame.focal.y;
    let j = mat3x3<f32>(
        vec3<f32>(fx / t.z, 0.0, 0.0),
        vec3<f32>(0.0, fy / t.z, 0.0),
        vec3<f32>(-fx * tx / (t.z * t.z), -fy * ty / (t.z * t.z), 0.0),
    );
    let v = frame.view_from_world;
    let w = mat3x3<f32>(v[0].xyz, v[1].xyz, v[2].xyz);
    let jw = j * w;
    let cov2 = jw * cov3 * transpose(jw);

    let a = cov2[0][0] + 0.3;
    let b = cov2[0][1];
    let c = cov2[1][1] + 0.3;
    let det = a * c - b * b;
    if det == 0.0 || !is_finite(det) {
        atomicAdd(&stats[STAT_DEGENERATE], 1u);
        return;
    }
    let det_inv = 1.0 / det;
    let conic = vec3<f32>(c * det_inv, -b * det_inv, a * det_inv);
    let mid = 0.5 * (a + c);
    let disc = sqrt(max(0.1, mid * mid - det));
    let radius = ceil(3.0 * sqrt(max(mid + disc, mid - disc)));
    let xy = vec2<f32>(fx * t.x / t.z, fy * t.y / t.z) + frame.principal;
    if !(is_finite(radius) && is_finite(xy.x) && is_finite(xy.y) && is_finite(conic.x)
        && is_finite(conic.y) && is_finite(conic.z)) {
        atomicAdd(&stats[STAT_DEGENERATE], 1u);
        return;
    }

    let tile_extra = f32(TILE_SIZE - 1u);
    let rmin = vec2<u32>(tile_bound(xy.x - radius, frame.tiles.x), tile_bound(xy.y - radius, frame.tiles.y));
    let rmax = vec2<u32>(
        tile_bound(xy.x + radius + tile_extra, frame.tiles.x),
        tile_bound(xy.y + radius + tile_extra, frame.tiles.y),
    );
    if (rmax.x - rmin.x) * (rmax.y - rmin.y) == 0u {
        atomicAdd(&stats[STAT_OUTSIDE], 1u);
        return;
    }
    // Compensated, the low-pass spreads the splat without adding to its mass (Mip-Splatting):
    // opacity × √(det cov2 / det(cov2 + 0.3 I)). det cov2 is |r₀ × r₁|² for the rows r of
    // J·W·R·S (Binet–Cauchy), a sum of squares: taken as a·c − b² it cancels to noise for
    // needle-thin splats, where the square root magnifies it.
    var opacity = g.opacity;
    if frame.low_pass == 1u {
        let p = jw * m;
        let across = cross(vec3<f32>(p[0][0], p[1][0], p[2][0]), vec3<f32>(p[0][1], p[1][1], p[2][1]));
        opacity *= sqrt(dot(across, across) / det);
    }
    let conic_opacity = vec4<f32>(conic, opacity);
    // The reference lists every tile of the 3σ rectangle; only those the splat can reach matter
    // (it still counts as visible when it reaches none, as in the reference).
    let q_limit = reach_limit(opacity);
    var area = 0u;
    for (var ty = rmin.y; ty < rmax.y; ty++) {
        let span = row_span(xy, conic_opacity, q_limit, ty, rmin.x, rmax.x);
        area += span.y - span.x;
    }

    var p: Projected;
    p.conic_opacity = conic_opacity;
    p.xy = xy;
    p.depth = t.z;
    p.rect_min = rmin.x | (rmin.y << 16u);
    p.rect_max = rmax.x | (rmax.y << 16u);
    p.q_limit = q_limit;
    projected[i] = p;
    // Positive finite floats order like their bit patterns.
    depth_keys[i] = bitcast<u32>(t.z);
    touched[i] = area;
    atomicAdd(&stats[STAT_VISIBLE], 1u);
}
