//! The default reconstruction (no GUAVA weights): the photo's colours, mapped into UV space and
//! filled, become flat Gaussian discs on the body surface.
//!
//! - UV Gaussians, one per valid texel: a disc in its triangle's plane (frame axes 0 and 2; the
//!   thin axis is the normal, axis 1), its radius a fixed multiple of the texel's footprint on the
//!   source surface so neighbours overlap without holes; no offset from the surface.
//! - Template Gaussians, one per vertex: small isotropic blobs of the texture colour at the
//!   vertex's UV, which close the cracks along UV seams.
//!
//! Latent channels ([`DEFAULT_CHANNELS`] = 4): 0–2 RGB in [0, 1]; 3 the source confidence
//! (cosine between the surface normal and the source view ray, times the person mask, where the
//! photo saw the texel; half the mirror texel's where it was filled by symmetry; 0 where
//! inpainted), which a refiner can use to trust observed regions over filled ones.

use std::collections::BTreeMap;

use glam::{Vec2, Vec3};

use super::fill::FilledTexture;
use super::uv_map::UvMap;
use crate::avatar::{Avatar, AvatarKind, LocalGaussians, UvGaussians};
use crate::body::{BodyModel, PosedBody, triangle_frames};
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
    /// Template Gaussians' standard deviation relative to the mean edge length at their vertex.
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
    // Metres per texel side on each triangle: √(surface area / UV area in texels).
    let footprint: Vec<f32> = body
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| posed.vertices[i as usize]);
            let [ua, ub, uc] = t.map(|i| body.uvs[i as usize] * size);
            let area = 0.5 * (b - a).cross(c - a).length();
            let uv_area = 0.5 * (ub - ua).perp_dot(uc - ua).abs();
            if uv_area > 0.0 {
                (area / uv_area).sqrt()
            } else {
                0.0
            }
        })
        .collect();

    let mut out = UvGaussians::default();
    for &texel in &uv.texels {
        let i = texel as usize;
        let f = uv.triangle[i] as usize;
        let (sigma, fp) = (frames[f].scale, footprint[f]);
        if !(sigma > 0.0 && fp > 0.0) {
            continue;
        }
        let r = style.radius * fp / sigma;
        out.triangles.push(f as u32);
        out.barycentrics.push(uv.bary[i]);
        out.offsets.push([0.0; 3]);
        out.local.rotations.push([1.0, 0.0, 0.0, 0.0]);
        out.local.scales.push([r, style.thickness * r, r]);
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
    let mut template = LocalGaussians::default();
    for (v, uv_point) in body.uvs.iter().enumerate() {
        let mean_edge = edge_sum[v] / edge_count[v].max(1) as f32;
        let (rgb, confidence) = lookup(texture, *uv_point);
        template.rotations.push([1.0, 0.0, 0.0, 0.0]);
        template.scales.push([style.template_radius * mean_edge; 3]);
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
        template,
        uv: out,
    }
}

/// Bilinear colour and nearest confidence of the filled texture at a UV point.
fn lookup(texture: &FilledTexture, uv: Vec2) -> (Vec3, f32) {
    let s = texture.size as usize;
    let (x, y) = (uv.x * s as f32 - 0.5, uv.y * s as f32 - 0.5);
    let rgb = bilinear_clamped(s, x, y, |k| Vec3::from(texture.rgb[k]));
    let max = (s - 1) as f32;
    let nearest = y.round().clamp(0.0, max) as usize * s + x.round().clamp(0.0, max) as usize;
    (rgb, texture.confidence[nearest])
}
