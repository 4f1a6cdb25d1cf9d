//! The rig pass: an avatar's Gaussians posed straight into the splatting pass's input (GUAVA
//! `ubody_gaussian.py:Ubody_Gaussian.forward`, notes/guava-pipeline.md §5; the CPU twin is
//! src/avatar/animate.rs, which this matches to 1e-5). Three entry points, one thread each per
//! item, so no thread branches on what kind of Gaussian it has:
//! - `frames`, per triangle: its frame R (columns: first-edge direction, normal, in-plane axis)
//!   and scale σ (`compute_face_orientation`, src/body/frames.rs), once for all its Gaussians;
//! - `template`, per vertex: template Gaussian i sits on posed vertex i and turns with
//!   q(T_i) ⊗ r, T_i its blended skinning matrix taken as given (roma's `rotmat_to_unitquat`),
//!   renormalised;
//! - `skinned`, per skinned Gaussian (beyond the body): μ = Σ w_k v_k + S·Δμ, r = q(S) ⊗ r,
//!   S = Σ w_k S_k the blend of its vertices' skinning, renormalised;
//! - `uv`, per UV Gaussian on triangle f: μ = σ_f·R_f·Δμ + Σ b_k v_k, r = q(R_f) ⊗ r, s = σ_f·s.
//! The output holds the template Gaussians, then the skinned, then the UV ones.
//! Only the posed vertices and their skinning rotations change per frame; everything else was
//! uploaded once with the avatar.

struct RigParams {
    template_count: u32,
    uv_count: u32,
    triangle_count: u32,
    skinned_count: u32,
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

struct SkinnedGaussian {
    vertices: vec4<u32>,
    weights: vec4<f32>,
    offset: vec3<f32>,
    opacity: f32,
    rot: vec4<f32>,
    scale: vec3<f32>,
    _pad: f32,
}

struct PosedVertex {
    // xyz, and in w whether the vertex is drawn (1) or hidden (0).
    position: vec4<f32>,
    // The linear part of the blended skinning transform, columns.
    skin: mat3x3<f32>,
}

// A posed triangle: its corners (σ in v0.w, whether it is drawn in v1.w) and its frame as a
// unit quaternion.
struct TriangleFrame {
    v0: vec4<f32>,
    v1: vec4<f32>,
    v2: vec4<f32>,
    rot: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: RigParams;
@group(0) @binding(1) var<storage, read> template_gaussians: array<TemplateGaussian>;
@group(0) @binding(2) var<storage, read> uv_gaussians: array<UvGaussian>;
@group(0) @binding(3) var<storage, read> triangles: array<u32>;
@group(0) @binding(4) var<storage, read> posed: array<PosedVertex>;
@group(0) @binding(5) var<storage, read_write> frames: array<TriangleFrame>;
@group(0) @binding(6) var<storage, read_write> gaussians: array<Gaussian>;
@group(0) @binding(7) var<storage, read> skinned_gaussians: array<SkinnedGaussian>;

// Hamilton product p ⊗ q of (w, x, y, z) quaternions.
fn quat_mul(p: vec4<f32>, q: vec4<f32>) -> vec4<f32> {
    let v = p.x * q.yzw + q.x * p.yzw + cross(p.yzw, q.yzw);
    return vec4<f32>(p.x * q.x - dot(p.yzw, q.yzw), v);
}

fn quat_normalize(q: vec4<f32>) -> vec4<f32> {
    let n = sqrt(dot(q, q));
    return select(vec4<f32>(1.0, 0.0, 0.0, 0.0), q / n, n > 0.0 && is_finite(n));
}

// v rotated by the unit quaternion q.
fn quat_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.yzw, v);
    return v + q.x * t + cross(q.yzw, t);
}

// Shepperd's method on the matrix as given: the largest of the trace and the diagonal picks the
// formula (ties go to the later diagonal entry, as the CPU's `max_by` does). Every candidate is
// computed and one selected, so no lane branches (a CPU adapter would run every branch anyway).
fn quat_from_matrix(m: mat3x3<f32>) -> vec4<f32> {
    // r(i, j) = m[j][i]: row i, column j.
    let d = vec3<f32>(m[0][0], m[1][1], m[2][2]);
    let t = d.x + d.y + d.z;
    let from_trace = vec4<f32>(1.0 + t, m[1][2] - m[2][1], m[2][0] - m[0][2], m[0][1] - m[1][0]);
    let from_x = vec4<f32>(m[1][2] - m[2][1], 1.0 - t + 2.0 * d.x, m[0][1] + m[1][0], m[0][2] + m[2][0]);
    let from_y = vec4<f32>(m[2][0] - m[0][2], m[1][0] + m[0][1], 1.0 - t + 2.0 * d.y, m[1][2] + m[2][1]);
    let from_z = vec4<f32>(m[0][1] - m[1][0], m[2][0] + m[0][2], m[2][1] + m[1][2], 1.0 - t + 2.0 * d.z);
    let y_wins = d.y >= d.x;
    let largest = select(d.x, d.y, y_wins);
    let z_wins = d.z >= largest;
    let diagonal = select(select(from_x, from_y, y_wins), from_z, z_wins);
    return quat_normalize(select(diagonal, from_trace, t >= max(largest, d.z)));
}

// The reference's guarded length: sqrt(max(x·x, 1e-20)), so zero vectors normalise to zero.
fn safe_length(x: vec3<f32>) -> f32 {
    return sqrt(max(dot(x, x), 1e-20));
}

@compute @workgroup_size(256)
fn frames_main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    // No branch: llvmpipe turns a load or store inside one into a loop over the lanes. Threads
    // past the end work on the last item and store the same values it does.
    let id = flat_id(wid, nwg, lid, 256u);
    let f = min(id, params.triangle_count - 1u);
    let p0 = posed[triangles[3u * f]].position;
    let p1 = posed[triangles[3u * f + 1u]].position;
    let p2 = posed[triangles[3u * f + 2u]].position;
    let v0 = p0.xyz;
    let v1 = p1.xyz;
    let v2 = p2.xyz;
    let e0 = v1 - v0;
    let a0 = e0 / safe_length(e0);
    let n = cross(a0, v2 - v0);
    let a1 = n / safe_length(n);
    let m = cross(a1, a0);
    let a2 = -m / safe_length(m);
    let sigma = (safe_length(e0) + abs(dot(a2, v2 - v0))) / 2.0;
    // A triangle is drawn where all its corners are (a hand out of the photo's view is not).
    let seen = min(p0.w, min(p1.w, p2.w));
    var out: TriangleFrame;
    out.v0 = vec4<f32>(v0, sigma);
    out.v1 = vec4<f32>(v1, seen);
    out.v2 = vec4<f32>(v2, 0.0);
    out.rot = quat_from_matrix(mat3x3<f32>(a0, a1, a2));
    frames[f] = out;
}

@compute @workgroup_size(256)
fn template_main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let id = flat_id(wid, nwg, lid, 256u);
    let i = min(id, params.template_count - 1u);
    let t = template_gaussians[i];
    let v = posed[i];
    var g: Gaussian;
    g.pos = v.position.xyz;
    g.rot = quat_normalize(quat_mul(quat_from_matrix(v.skin), t.rot));
    g.scale = t.scale;
    g.opacity = t.opacity * v.position.w;
    g._pad = 0.0;
    gaussians[i] = g;
}

@compute @workgroup_size(256)
fn uv_main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let id = flat_id(wid, nwg, lid, 256u);
    let j = min(id, params.uv_count - 1u);
    let u = uv_gaussians[j];
    let f = frames[u.triangle];
    let sigma = f.v0.w;
    let anchor = u.bary.x * f.v0.xyz + u.bary.y * f.v1.xyz + u.bary.z * f.v2.xyz;
    var g: Gaussian;
    g.pos = sigma * quat_rotate(f.rot, u.offset) + anchor;
    g.rot = quat_mul(f.rot, u.rot);
    g.scale = u.scale * sigma;
    g.opacity = u.opacity * f.v1.w;
    g._pad = 0.0;
    gaussians[params.template_count + params.skinned_count + j] = g;
}

@compute @workgroup_size(256)
fn skinned_main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let id = flat_id(wid, nwg, lid, 256u);
    let i = min(id, params.skinned_count - 1u);
    let k = skinned_gaussians[i];
    var anchor = vec3<f32>(0.0);
    var skin = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var c = 0u; c < 4u; c++) {
        let v = posed[k.vertices[c]];
        anchor += k.weights[c] * v.position.xyz;
        skin += v.skin * k.weights[c];
    }
    var g: Gaussian;
    g.pos = anchor + skin * k.offset;
    g.rot = quat_normalize(quat_mul(quat_from_matrix(skin), k.rot));
    g.scale = k.scale;
    g.opacity = k.opacity;
    g._pad = 0.0;
    gaussians[params.template_count + i] = g;
}
