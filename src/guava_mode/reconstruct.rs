//! GUAVA mode's reconstruction (`ubody_gaussian.py:Ubody_Gaussian_inferer.forward`, notes §4):
//! encoder on the photo → EHM in the source pose → f_map2 sampled at each projected vertex →
//! template decoder; [RGB ‖ f_map1] inverse-texture-mapped into UV space with face visibility →
//! UV decoder → UV Gaussians bound to their texels' triangles, pruned at opacity ≤ 0.001.
//!
//! Where this departs from the reference: face visibility comes from our z-buffer, which leaves
//! out triangles with a corner within 1 mm of the camera plane (PyTorch3D's keeps them); and a
//! body converted without the reference's texel map gets our own rasterization of its UV layout
//! ([`uv_map`]).

use std::collections::BTreeMap;

use glam::{Mat4, Vec3};

use super::models::GuavaModels;
use super::sample::{Padding, grid_sample, project_ndc};
use crate::avatar::{Avatar, AvatarKind, LocalGaussians, UvGaussians};
use crate::body::{EhmModel, Posable, PosedBody};
use crate::camera::Camera;
use crate::photo::SourceImage;
use crate::progress::{Stage, StageClock};
use crate::raster::rasterize;
use crate::reconstruct::{ReconstructError, Report, UvMap};
use crate::tracking::{EhmIdentityRecord, SourceView};

/// UV Gaussians at or below this opacity are dropped (`cfg.opacity_threshold`).
pub const PRUNE_OPACITY: f32 = 0.001;

/// The EHM body's texel map at `size`²: the reference's own (OpenCV's fill, stored by
/// `tools/convert_ehm.py`) when the body carries one of that size, else our rasterization of its
/// per-corner texture coordinates (v flipped as the reference flips them, so row 0 is the top of
/// GUAVA's UV map), which differs from OpenCV's on boundary texels.
pub fn uv_map(body: &EhmModel, size: u32) -> UvMap {
    match &body.reference_texels {
        Some(r) if r.size == size => UvMap {
            size,
            texels: (0..r.triangle.len() as u32)
                .filter(|&i| r.triangle[i as usize] >= 0)
                .collect(),
            triangle: r.triangle.clone(),
            bary: r.bary.clone(),
            mirror: vec![-1; r.triangle.len()],
        },
        _ => UvMap::new(&body.texcoords, &body.triangle_uvs, size),
    }
}

/// Reconstructs `image` (already at the encoder's size, masked) seen from `view` on `body`, built
/// with the source's identity (`body.identity`, which the avatar keeps). `uv` is [`uv_map`] at
/// the models' UV size. Progress and cancellation as in
/// [`crate::reconstruct::reconstruct_default`].
pub fn reconstruct_guava(
    models: &mut GuavaModels,
    body: &EhmModel,
    uv: &UvMap,
    view: &SourceView,
    image: &SourceImage,
    source_name: &str,
    progress: &mut dyn FnMut(Stage) -> bool,
) -> Result<(Avatar, Report), ReconstructError> {
    let d = models.dims;
    let n = body.body.template.len();
    let mut mismatch = Vec::new();
    if image.size as usize != d.image {
        mismatch.push(format!(
            "the image is {0}², the encoder takes {1}²",
            image.size, d.image
        ));
    }
    if uv.size as usize != d.uv {
        mismatch.push(format!(
            "the UV map is {0}², the UV decoder makes {1}²",
            uv.size, d.uv
        ));
    }
    if n != d.vertices {
        mismatch.push(format!(
            "body {:?} has {n} vertices, the template decoder was exported for {}",
            body.name, d.vertices
        ));
    }
    if !mismatch.is_empty() {
        return Err(ReconstructError::Models(format!(
            "GUAVA models in {}: {}",
            models.dir.display(),
            mismatch.join("; ")
        )));
    }
    let mut report = Report {
        texels: uv.len(),
        ..Default::default()
    };
    let mut clock = StageClock::default();
    let w2c = view.camera.view_from_world;
    let invtanfov = view.camera.invtanfov();
    // get_cam_dirs: the world-to-camera rotation's third column, as the reference computes it.
    let cam_dir = w2c.z_axis.truncate();

    clock.start(Stage::Encode, progress)?;
    let planar: Vec<f32> = (0..3)
        .flat_map(|c| image.rgb.iter().skip(c).step_by(3).copied())
        .collect();
    let encoded = models.encode(&planar)?;

    clock.start(Stage::Pose, progress)?;
    let mut posed = PosedBody::default();
    body.pose(&view.pose, &mut posed)?;

    clock.start(Stage::Rasterize, progress)?;
    let camera = Camera::guava(w2c, d.features as u32, invtanfov);
    let fragments = rasterize(&posed.vertices, &body.triangles, &camera);
    let mut visible = vec![false; body.triangles.len()];
    for &t in fragments.triangle.iter().filter(|&&t| t >= 0) {
        visible[t as usize] = true;
    }
    report.visible_faces = visible.iter().filter(|&&v| v).count();
    if report.visible_faces == 0 {
        return Err(ReconstructError::NothingVisible);
    }

    clock.start(Stage::TextureMap, progress)?;
    let projection = Projection { w2c, invtanfov };
    let sampled = projection.sample_vertices(
        &posed.vertices,
        &encoded.vertex_features,
        d.vertex_channels,
        d.features,
    );
    let (uv_features, observed) = projection.texture_map(
        uv,
        &posed.vertices,
        &body.triangles,
        &visible,
        &encoded.pixel_features,
        d.pixel_channels,
        d.features,
    );
    report.observed = observed;

    clock.start(Stage::DecodeVertices, progress)?;
    let vertex = models.decode_vertices(sampled, &encoded, cam_dir)?;

    clock.start(Stage::DecodeUv, progress)?;
    let uv_out = models.decode_uv(uv_features, &encoded, cam_dir)?;

    clock.start(Stage::Gaussians, progress)?;
    let c = d.colors;
    let template = LocalGaussians {
        rotations: vertex.rotations.chunks_exact(4).map(to4).collect(),
        scales: vertex.scales.chunks_exact(3).map(to3).collect(),
        opacities: vertex.opacities,
        features: activated(vertex.colors, c),
    };
    let mut gaussians = UvGaussians::default();
    for &i in &uv.texels {
        let i = i as usize;
        if uv_out.opacities[i] <= PRUNE_OPACITY {
            report.pruned += 1;
            continue;
        }
        gaussians.triangles.push(uv.triangle[i] as u32);
        gaussians.barycentrics.push(uv.bary[i]);
        gaussians
            .offsets
            .push(to3(&uv_out.local_pos[3 * i..3 * i + 3]));
        let local = &mut gaussians.local;
        local
            .rotations
            .push(to4(&uv_out.rotations[4 * i..4 * i + 4]));
        local.scales.push(to3(&uv_out.scales[3 * i..3 * i + 3]));
        local.opacities.push(uv_out.opacities[i]);
        local
            .features
            .extend(activated(uv_out.colors[c * i..c * (i + 1)].to_vec(), c));
    }
    let avatar = Avatar {
        kind: AvatarKind::Guava,
        body: body.name.clone(),
        body_vertices: n,
        body_triangles: body.triangles.len(),
        channels: c,
        identity: identity(body, &view.pose.coefficients),
        ehm_identity: Some(EhmIdentityRecord::of(&body.identity)),
        source: source_name.into(),
        source_view: Some(view.clone()),
        displacements: Vec::new(),
        template,
        uv: gaussians,
        skinned: Default::default(),
        outside: 0,
    };
    report.timings = clock.finish();
    Ok((avatar, report))
}

/// The source camera as GUAVA's sampling sees it.
#[derive(Clone, Copy, Debug)]
pub struct Projection {
    pub w2c: Mat4,
    pub invtanfov: f32,
}

impl Projection {
    /// `sample_prj_feature`: the `channels` planes of `side`² `maps` at each vertex's projection
    /// (border padding); vertex-major, `channels` per vertex.
    pub fn sample_vertices(
        &self,
        vertices: &[Vec3],
        maps: &[f32],
        channels: usize,
        side: usize,
    ) -> Vec<f32> {
        let mut sampled = vec![0.0; vertices.len() * channels];
        for (v, out) in vertices.iter().zip(sampled.chunks_exact_mut(channels)) {
            let ndc = project_ndc(&self.w2c, self.invtanfov, *v);
            grid_sample(maps, channels, side, ndc, Padding::Border, out);
        }
        sampled
    }

    /// `convert_pixel_feature_to_uv`: each valid texel's surface point on the posed mesh,
    /// projected, samples `maps` (zero padding); texels of faces not `visible` stay zero.
    /// Returns `channels` planes of the UV map and how many texels received anything.
    #[allow(clippy::too_many_arguments)]
    pub fn texture_map(
        &self,
        uv: &UvMap,
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        visible: &[bool],
        maps: &[f32],
        channels: usize,
        side: usize,
    ) -> (Vec<f32>, usize) {
        let texels = (uv.size * uv.size) as usize;
        let mut out = vec![0.0; channels * texels];
        let mut texel = vec![0.0; channels];
        let mut observed = 0;
        for &i in &uv.texels {
            let i = i as usize;
            if !visible[uv.triangle[i] as usize] {
                continue;
            }
            let point = uv.point(i, vertices, triangles);
            let ndc = project_ndc(&self.w2c, self.invtanfov, point);
            grid_sample(maps, channels, side, ndc, Padding::Zeros, &mut texel);
            observed += usize::from(texel.iter().any(|&f| f != 0.0));
            for (c, &f) in texel.iter().enumerate() {
                out[c * texels + i] = f;
            }
        }
        (out, observed)
    }
}

/// Colours with the first three channels through a sigmoid (`Ubody_Gaussian.__init__`: RGB in
/// [0, 1]; the other channels stay raw for the refiner).
fn activated(mut colors: Vec<f32>, channels: usize) -> Vec<f32> {
    for gaussian in colors.chunks_exact_mut(channels) {
        for v in &mut gaussian[..3] {
            *v = 1.0 / (1.0 + (-*v).exp());
        }
    }
    colors
}

/// EHM's identity coefficients (SMPL-X and FLAME shape) that the source pose sets.
fn identity(body: &EhmModel, coefficients: &[f32]) -> BTreeMap<String, f32> {
    body.parameter_names()
        .zip(coefficients)
        .enumerate()
        .filter(|&(i, (_, &v))| v != 0.0 && body.is_identity_parameter(i))
        .map(|(_, (name, &v))| (name.to_string(), v))
        .collect()
}

fn to3(s: &[f32]) -> [f32; 3] {
    [s[0], s[1], s[2]]
}

fn to4(s: &[f32]) -> [f32; 4] {
    [s[0], s[1], s[2], s[3]]
}
