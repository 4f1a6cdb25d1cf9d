//! The rig pass: one thread per Gaussian poses an avatar's Gaussians straight into the splatting
//! pass's input (GUAVA `ubody_gaussian.py:Ubody_Gaussian.forward`, notes/guava-pipeline.md §5;
//! the CPU twin is src/avatar/animate.rs, which this matches to 1e-5).
//! - Template Gaussian i sits on posed vertex i and turns with q(T_i) ⊗ r, T_i its blended
//!   skinning matrix taken as given (roma's `rotmat_to_unitquat`), renormalised.
//! - UV Gaussian on triangle f: μ = σ_f·R_f·Δμ + Σ b_k v_k, r = q(R_f) ⊗ r, s = σ_f·s, with R_f and
//!   σ_f the triangle's frame (`compute_face_orientation`, src/body/frames.rs).
//! Only the posed vertices and their skinning rotations change per frame; everything else was
//! uploaded once with the avatar.

struct RigParams {
    template_count: u32,
    uv_count: u32,
    _pad: vec2<u32>,
}

// Activated attributes in the frame they are bound to (a vertex's skinning, a triangle's frame).
struct TemplateGaussian {
    rot: vec4<f32>,
    scale: vec3<f32>,
    opacity: f32,
}

struct UvGaussian {
    bary: vec3<f32>,
    triangle: u32,
    offset: vec3<f32>,
    opacity: f32,
    rot: vec4<f32>,
    scale: vec3<f32>,
    _pad: f32,
}

struct PosedVertex {
    position: vec4<f32>,
    // The linear part of the blended skinning transform, columns.
    skin: mat3x3<f32>,
}

@group(0) @binding(0) var<uniform> params: RigParams;
@group(0) @binding(1) var<storage, read> template_gaussians: array<TemplateGaussian>;
@group(0) @binding(2) var<storage, read> uv_gaussians: array<UvGaussian>;
@group(0) @binding(3) var<storage, read> triangles: array<u32>;
@group(0) @binding(4) var<storage, read> posed: array<PosedVertex>;
@group(0) @binding(5) var<storage, read_write> gaussians: array<Gaussian>;

// Hamilton product p ⊗ q of (w, x, y, z) quaternions.
fn quat_mul(p: vec4<f32>, q: vec4<f32>) -> vec4<f32> {
    let v = p.x * q.yzw + q.x * p.yzw + cross(p.yzw, q.yzw);
    return vec4<f32>(p.x * q.x - dot(p.yzw, q.yzw), v);
}

fn quat_normalize(q: vec4<f32>) -> vec4<f32> {
    let n = sqrt(dot(q, q));
    if n > 0.0 && is_finite(n) {
        return q / n;
    }
    return vec4<f32>(1.0, 0.0, 0.0, 0.0);
}

// Shepperd's method on the matrix as given: the largest of the diagonal and the trace picks the
// formula (ties go to the later diagonal entry, as the CPU's `max_by` does).
fn quat_from_matrix(m: mat3x3<f32>) -> vec4<f32> {
    // r(i, j) = m[j][i]: row i, column j.
    let d = vec3<f32>(m[0][0], m[1][1], m[2][2]);
    let trace = d.x + d.y + d.z;
    var i = 0u;
    if d.y >= d[i] {
        i = 1u;
    }
    if d.z >= d[i] {
        i = 2u;
    }
    if trace >= d[i] {
        return quat_normalize(vec4<f32>(
            1.0 + trace,
            m[1][2] - m[2][1],
            m[2][0] - m[0][2],
            m[0][1] - m[1][0],
        ));
    }
    let j = (i + 1u) % 3u;
    let k = (i + 2u) % 3u;
    var xyz = vec3<f32>(0.0);
    xyz[i] = 1.0 - trace + 2.0 * m[i][i];
    xyz[j] = m[i][j] + m[j][i];
    xyz[k] = m[i][k] + m[k][i];
    return quat_normalize(vec4<f32>(m[j][k] - m[k][j], xyz));
}

// The reference's guarded length: sqrt(max(x·x, 1e-20)), so zero vectors normalise to zero.
fn safe_length(x: vec3<f32>) -> f32 {
    return sqrt(max(dot(x, x), 1e-20));
}

@compute @workgroup_size(256)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = flat_id(wid, nwg, lid, 256u);
    var g: Gaussian;
    if i < params.template_count {
        let t = template_gaussians[i];
        let v = posed[i];
        g.pos = v.position.xyz;
        g.rot = quat_normalize(quat_mul(quat_from_matrix(v.skin), t.rot));
        g.scale = t.scale;
        g.opacity = t.opacity;
    } else if i < params.template_count + params.uv_count {
        let u = uv_gaussians[i - params.template_count];
        let f = 3u * u.triangle;
        let v0 = posed[triangles[f]].position.xyz;
        let v1 = posed[triangles[f + 1u]].position.xyz;
        let v2 = posed[triangles[f + 2u]].position.xyz;
        let e0 = v1 - v0;
        let a0 = e0 / safe_length(e0);
        let n = cross(a0, v2 - v0);
        let a1 = n / safe_length(n);
        let m = cross(a1, a0);
        let a2 = -m / safe_length(m);
        let sigma = (safe_length(e0) + abs(dot(a2, v2 - v0))) / 2.0;
        let frame = mat3x3<f32>(a0, a1, a2);
        let anchor = u.bary.x * v0 + u.bary.y * v1 + u.bary.z * v2;
        g.pos = sigma * (frame * u.offset) + anchor;
        g.rot = quat_mul(quat_from_matrix(frame), u.rot);
        g.scale = u.scale * sigma;
        g.opacity = u.opacity;
    } else {
        return;
    }
    g._pad = 0.0;
    gaussians[i] = g;
}
