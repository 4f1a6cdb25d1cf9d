//! The default reconstruction (no GUAVA weights): the photo's colours, mapped into UV space and
//! filled, become flat Gaussian discs on the body surface.
//!
//! - UV Gaussians, one per valid texel: a disc in its triangle's plane (frame axes 0 and 2; the
//!   thin axis is the normal, axis 1), its axes a fixed multiple of the texel's footprint on the
//!   source surface along each direction ([`Footprint`]), so neighbours overlap without holes;
//!   no offset from the surface.
//! - Template Gaussians, one per vertex: small discs of the texture colour at the vertex's UV in
//!   its tangent plane, which close the cracks along UV seams.
//!
//! Latent channels ([`DEFAULT_CHANNELS`] = 4): 0–2 RGB in [0, 1]; 3 the source confidence
//! (cosine between the surface normal and the source view ray, times the person mask, where the
//! photo saw the texel; half the mirror texel's where it was filled by symmetry; 0 where
//! inpainted), which a refiner can use to trust observed regions over filled ones.

use std::collections::BTreeMap;

use glam::{Mat2, Mat3A, Vec2, Vec3};

use super::fill::FilledTexture;
use super::uv_map::UvMap;
use crate::avatar::{Avatar, AvatarKind, LocalGaussians, UvGaussians, quat_from_matrix, quat_mul};
use crate::body::{BodyModel, PosedBody, TriangleFrame, triangle_frames};
use crate::photo::bilinear_clamped;

pub const DEFAULT_CHANNELS: usize = 4;

/// Shape of the default reconstruction's Gaussians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscStyle {
    /// Disc standard deviation in texel footprints (0.5 would just touch its neighbours' centres).
    pub radius: f32,
    /// Thickness (standard deviation along the normal) relative to the radius.
    pub thickness: f32,
    pub opacity: f32,
    /// Template discs' standard deviation relative to the mean edge length at their vertex.
    pub template_radius: f32,
    pub template_opacity: f32,
}

impl Default for DiscStyle {
    fn default() -> Self {
        Self {
            radius: 0.6,
            thickness: 0.05,
            opacity: 0.95,
            template_radius: 0.25,
            template_opacity: 0.5,
        }
    }
}

/// Builds the avatar from the filled texture. `posed` is the body in the source pose (disc sizes
/// are measured there, in units of each triangle's scale σ, so they follow the surface when posed).
pub fn build(
    body: &BodyModel,
    posed: &PosedBody,
    uv: &UvMap,
    texture: &FilledTexture,
    style: &DiscStyle,
    identity: BTreeMap<String, f32>,
    source: String,
) -> Avatar {
    let c = DEFAULT_CHANNELS;
    let size = uv.size as f32;
    let mut frames = Vec::new();
    triangle_frames(&posed.vertices, &body.triangles, &mut frames);
    let footprints: Vec<Option<Footprint>> = body
        .triangles
        .iter()
        .zip(&frames)
        .map(|(t, frame)| {
            Footprint::of(
                t.map(|i| posed.vertices[i as usize]),
                t.map(|i| body.uvs[i as usize] * size),
                frame,
            )
        })
        .collect();

    let mut out = UvGaussians::default();
    for &texel in &uv.texels {
        let i = texel as usize;
        let f = uv.triangle[i] as usize;
        let Some(fp) = footprints[f] else {
            continue;
        };
        let sigma = frames[f].scale;
        let [major, minor] = fp.axes.map(|a| style.radius * a / sigma);
        out.triangles.push(f as u32);
        out.barycentrics.push(uv.bary[i]);
        out.offsets.push([0.0; 3]);
        out.local.rotations.push(fp.rotation);
        out.local
            .scales
            .push([major, style.thickness * minor, minor]);
        out.local.opacities.push(style.opacity);
        out.local.features.extend(texture.rgb[i]);
        out.local.features.push(texture.confidence[i]);
    }

    // Mean length of the edges at each vertex, for the template blobs' size.
    let mut edge_sum = vec![0.0f32; body.vertices.len()];
    let mut edge_count = vec![0u32; body.vertices.len()];
    for t in &body.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let l = posed.vertices[a].distance(posed.vertices[b]);
            for v in [a, b] {
                edge_sum[v] += l;
                edge_count[v] += 1;
            }
        }
    }
    // Template discs lie in the surface's tangent plane (a round blob would stand out past the
    // silhouette by its radius): the frame with the smooth normal as axis 1, relative to the
    // vertex's skinning rotation, which the rig turns it by.
    let normals = body.normals_of(&posed.vertices);
    let mut template = LocalGaussians::default();
    for (v, uv_point) in body.uvs.iter().enumerate() {
        let mean_edge = edge_sum[v] / edge_count[v].max(1) as f32;
        let (rgb, confidence) = lookup(texture, *uv_point);
        let n = normals[v];
        let tangent = n.any_orthonormal_vector();
        let frame = quat_from_matrix(Mat3A::from_cols(
            tangent.into(),
            n.into(),
            tangent.cross(n).into(),
        ));
        let skin = quat_from_matrix(posed.skin[v].matrix3);
        let inverse_skin = [skin[0], -skin[1], -skin[2], -skin[3]];
        let radius = style.template_radius * mean_edge;
        template.rotations.push(if n == Vec3::ZERO {
            [1.0, 0.0, 0.0, 0.0]
        } else {
            quat_mul(inverse_skin, frame)
        });
        template
            .scales
            .push([radius, style.thickness * radius, radius]);
        template.opacities.push(style.template_opacity);
        template.features.extend(rgb.to_array());
        template.features.push(confidence);
    }
    Avatar {
        kind: AvatarKind::DefaultReconstruction,
        body: body.name.clone(),
        body_vertices: body.vertices.len(),
        body_triangles: body.triangles.len(),
        channels: c,
        identity,
        ehm_identity: None,
        source,
        source_view: None,
        displacements: Vec::new(),
        template,
        uv: out,
        skinned: Default::default(),
        outside: 0,
    }
}

/// The surface a texel covers on one triangle: the image of the texel square under the
/// triangle's UV → surface map J, whose covariance J·Jᵀ gives a disc's two axes (metres per texel
/// along each) and their direction in the triangle's plane. A triangle the clothing layer
/// stretches gets discs stretched the same way, not round ones as wide as its longest side.
#[derive(Clone, Copy, Debug)]
struct Footprint {
    /// Rotation about the triangle's normal (frame axis 1) taking frame axis 0 to the major axis.
    rotation: [f32; 4],
    /// Metres per texel along the major and the minor axis.
    axes: [f32; 2],
}

impl Footprint {
    /// The footprint of a triangle with corners `v` (posed) and `uv` (in texels), in `frame`;
    /// `None` when it has no area on either side.
    fn of(v: [Vec3; 3], uv: [Vec2; 3], frame: &TriangleFrame) -> Option<Self> {
        let (x, y) = (frame.rotation.x_axis, frame.rotation.z_axis);
        let plane = |p: Vec3| Vec2::new((p - v[0]).dot(x), (p - v[0]).dot(y));
        let surface = Mat2::from_cols(plane(v[1]), plane(v[2]));
        let texels = Mat2::from_cols(uv[1] - uv[0], uv[2] - uv[0]);
        if texels.determinant().abs() < 1e-9 || surface.determinant() == 0.0 {
            return None;
        }
        let j = surface * texels.inverse();
        let c = j * j.transpose();
        let (a, b, d) = (c.x_axis.x, c.x_axis.y, c.y_axis.y);
        let mean = 0.5 * (a + d);
        let spread = (0.25 * (a - d) * (a - d) + b * b).sqrt();
        let (major, minor) = (mean + spread, (mean - spread).max(0.0));
        let angle = 0.5 * (2.0 * b).atan2(a - d);
        // Turning frame axis 0 (x) towards axis 2 (y) by `angle` is a turn about axis 1 by −angle.
        let half = -0.5 * angle;
        let rotation = [half.cos(), 0.0, half.sin(), 0.0];
        // A texel on a triangle far smaller than itself (one nearly collinear in the UV layout,
        // as on the fingers) would stand for metres of surface: no disc reaches past its
        // triangle's longest edge (there were 20 cm streaks on the demo portrait's hand).
        let longest = (0..3).fold(0.0f32, |m, k| m.max(v[k].distance(v[(k + 1) % 3])));
        let major = major.sqrt().min(longest);
        let axes = [major, minor.sqrt().clamp(major / MAX_ANISOTROPY, major)];
        axes.iter()
            .all(|s| s.is_finite() && *s > 0.0)
            .then_some(Self { rotation, axes })
    }
}

/// Discs are at most this many times longer than wide (a texel on a sliver of a triangle).
const MAX_ANISOTROPY: f32 = 8.0;

/// Bilinear colour and nearest confidence of the filled texture at a UV point.
fn lookup(texture: &FilledTexture, uv: Vec2) -> (Vec3, f32) {
    let s = texture.size as usize;
    let (x, y) = (uv.x * s as f32 - 0.5, uv.y * s as f32 - 0.5);
    let rgb = bilinear_clamped(s, x, y, |k| Vec3::from(texture.rgb[k]));
    let max = (s - 1) as f32;
    let nearest = y.round().clamp(0.0, max) as usize * s + x.round().clamp(0.0, max) as usize;
    (rgb, texture.confidence[nearest])
}
