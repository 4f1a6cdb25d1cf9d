// Mesh view of a posed body: headlight-shaded triangles, an optional wireframe of the triangle
// edges drawn over them, and the blit that puts the offscreen image into the viewer's pass
// (blended: an overlay's empty pixels are transparent).

struct MeshUniforms {
    clip_from_world: mat4x4<f32>,
    view_from_world: mat4x4<f32>,
    surface: vec4<f32>,
    wire: vec4<f32>,
}

@group(0) @binding(0) var<uniform> mesh: MeshUniforms;

struct MeshIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

struct MeshOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal_view: vec3<f32>,
    @location(1) position_view: vec3<f32>,
}

@vertex
fn vs_mesh(in: MeshIn) -> MeshOut {
    var out: MeshOut;
    out.clip = mesh.clip_from_world * vec4<f32>(in.position, 1.0);
    out.position_view = (mesh.view_from_world * vec4<f32>(in.position, 1.0)).xyz;
    out.normal_view = (mesh.view_from_world * vec4<f32>(in.normal, 0.0)).xyz;
    return out;
}

@fragment
fn fs_shaded(in: MeshOut) -> @location(0) vec4<f32> {
    // Two-sided Lambert from a light at the eye: the view direction is the light direction.
    let to_eye = normalize(-in.position_view);
    var n = in.normal_view;
    let len = length(n);
    n = select(to_eye, n / len, len > 1e-12);
    let lambert = abs(dot(n, to_eye));
    return vec4<f32>(mesh.surface.rgb * (0.25 + 0.75 * lambert), mesh.surface.a);
}

@fragment
fn fs_wire() -> @location(0) vec4<f32> {
    return mesh.wire;
}

// Blit: the offscreen image, one texel per pixel, into the viewer's target.
struct BlitParams {
    size: vec2<u32>,
    srgb_target: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> blit: BlitParams;
@group(0) @binding(1) var image: texture_2d<f32>;

@vertex
fn vs_blit(@builtin(vertex_index) v: u32) -> FullscreenOut {
    return fullscreen_vertex(v);
}

@fragment
fn fs_blit(in: FullscreenOut) -> @location(0) vec4<f32> {
    let p = fullscreen_texel(in.uv, blit.size);
    let texel = textureLoad(image, p, 0);
    var c = texel.rgb;
    if blit.srgb_target != 0u {
        c = srgb_to_linear(c);
    }
    return vec4<f32>(c, texel.a);
}
