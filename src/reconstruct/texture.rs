//! Inverse texture mapping (paper Sec. 3.3): each UV texel's surface point on the posed source
//! mesh is projected into the source photo and the photo is sampled there; texels the source
//! camera cannot see get nothing. Visibility is a per-texel depth test against the z-buffer of
//! the posed mesh, so a hand in front of the chest never paints the chest behind it.

use glam::Vec3;

use super::uv_map::UvMap;
use crate::body::BodyModel;
use crate::camera::Camera;
use crate::photo::SourceImage;
use crate::raster::{Fragments, RASTER_NEAR};

/// A texel closer to the camera than the z-buffer by less than this many pixel footprints still
/// counts as the visible surface: covers the depth change across one pixel on a surface inclined
/// up to ~80° to the view (tan 80° ≈ 5.7), below which [`MIN_COSINE`] rejects it anyway.
const DEPTH_TOLERANCE_PIXELS: f32 = 6.0;
/// Parts behind the face's openings, each opening's a compartment of its own: a few millimetres
/// behind closed lips or lids, within [`DEPTH_TOLERANCE_PIXELS`] of them, so the depth test
/// alone gave the teeth the lips' colour, and the eyeballs the lids' and lashes', as if they
/// were seen. The rest of the body is compartment 0.
const COMPARTMENTS: [&[&str]; 2] = [
    &["teeth", "tongue", "mouth_cavity"],
    &[
        "eye_front.L",
        "eye_front.R",
        "eye_back.L",
        "eye_back.R",
        "eye_cavity.L",
        "eye_cavity.R",
    ],
];
/// Surfaces seen more obliquely than this (cosine of the angle between normal and view ray) are
/// too foreshortened to sample: one pixel smears over many texels.
pub const MIN_COSINE: f32 = 0.2;
/// Texels whose projection lands mostly outside the person mask are not the person.
const MIN_MASK: f32 = 0.5;
/// At least this much of the bilinear weight must fall on pixels of the texel's own surface.
const MIN_OWN_WEIGHT: f32 = 0.25;

/// The source photo in UV space.
#[derive(Clone, Debug, PartialEq)]
pub struct UvTexture {
    pub size: u32,
    /// Per texel (row-major) colour; zero where not observed.
    pub rgb: Vec<[f32; 3]>,
    /// How well the source saw each texel: the cosine between surface normal and view ray,
    /// times the mask; 0 = not seen (hidden, off-image, outside the mask or too oblique).
    pub confidence: Vec<f32>,
}

impl UvTexture {
    pub fn observed(&self) -> usize {
        self.confidence.iter().filter(|&&c| c > 0.0).count()
    }
}

/// Per triangle of `body`: the compartment it lies in ([`COMPARTMENTS`], all three corners; 1
/// the mouth's, 2 the eyes', 0 elsewhere). The depth tolerance joins a texel to the surface in
/// front of it only within one compartment: on the same side of the lips or the lids.
fn compartments(body: &BodyModel) -> Vec<u8> {
    let of = |v: u32| {
        let part = body.part_of(v as usize);
        COMPARTMENTS
            .iter()
            .position(|parts| part.is_some_and(|p| parts.contains(&p)))
            .map_or(0, |k| k as u8 + 1)
    };
    body.triangles
        .iter()
        .map(|t| {
            let k = of(t[0]);
            if t.iter().all(|&v| of(v) == k) { k } else { 0 }
        })
        .collect()
}

/// Samples `source` for every valid texel of `uv` on `body` posed at `vertices`, seen by
/// `camera`; `fragments` is that mesh rasterized from `camera` at the source's size.
pub fn inverse_texture_map(
    uv: &UvMap,
    body: &BodyModel,
    vertices: &[Vec3],
    camera: &Camera,
    source: &SourceImage,
    fragments: &Fragments,
) -> UvTexture {
    Sampler::new(body, vertices, camera, source, fragments).texture(uv)
}

/// The photo seen at points of the posed surface: the depth test and the sampling, for the UV
/// map's texels ([`Sampler::texture`]) or any other point (finer where the map is coarse).
pub(super) struct Sampler<'a> {
    vertices: &'a [Vec3],
    triangles: &'a [[u32; 3]],
    camera: &'a Camera,
    source: &'a SourceImage,
    fragments: &'a Fragments,
    compartment: Vec<u8>,
    /// The camera's centre.
    eye: Vec3,
}

impl<'a> Sampler<'a> {
    pub(super) fn new(
        body: &'a BodyModel,
        vertices: &'a [Vec3],
        camera: &'a Camera,
        source: &'a SourceImage,
        fragments: &'a Fragments,
    ) -> Self {
        Self {
            vertices,
            triangles: &body.triangles,
            camera,
            source,
            fragments,
            compartment: compartments(body),
            eye: camera
                .view_from_world
                .inverse()
                .transform_point3(Vec3::ZERO),
        }
    }

    /// The photo in UV space: every valid texel of `uv` sampled.
    pub(super) fn texture(&self, uv: &UvMap) -> UvTexture {
        let n = (uv.size * uv.size) as usize;
        let mut out = UvTexture {
            size: uv.size,
            rgb: vec![[0.0; 3]; n],
            confidence: vec![0.0; n],
        };
        for &texel in &uv.texels {
            let i = texel as usize;
            let p = uv.point(i, self.vertices, self.triangles);
            if let Some((rgb, confidence)) = self.sample(uv.triangle[i] as u32, p) {
                out.rgb[i] = rgb;
                out.confidence[i] = confidence;
            }
        }
        out
    }

    /// The photo's colour at point `p` of triangle `t` and how well it is seen (the cosine
    /// between normal and view ray times the mask); `None` where the camera does not see it.
    pub(super) fn sample(&self, t: u32, p: Vec3) -> Option<([f32; 3], f32)> {
        let [v0, v1, v2] = self.triangles[t as usize].map(|k| self.vertices[k as usize]);
        let normal = (v1 - v0).cross(v2 - v0).normalize_or_zero();
        let cosine = normal.dot((self.eye - p).normalize_or_zero()).abs();
        if cosine < MIN_COSINE {
            return None;
        }
        let q = self.camera.project(p);
        if !q.is_finite() || q.z <= RASTER_NEAR {
            return None;
        }
        // Centre-at-integer coordinates, where the bilinear taps are the four nearest pixels.
        let at = q - Vec3::new(0.5, 0.5, 0.0);
        let (rgb, mask) = sample_surface(
            self.fragments,
            self.source,
            at,
            t as i32,
            &self.compartment,
            self.camera,
        )?;
        Some((rgb, cosine * mask))
    }

    /// The camera's centre.
    pub(super) fn eye(&self) -> Vec3 {
        self.eye
    }

    /// Where the camera sees point `p`, in pixels.
    pub(super) fn pixel(&self, p: Vec3) -> glam::Vec2 {
        self.camera.project(p).truncate()
    }
}

/// The photo's colour (un-premultiplied) and mask at `at`'s `(x, y)` from the bilinear taps that
/// show the texel's own surface (its triangle, or one in the same `compartment`, within the
/// depth tolerance of depth `at.z`). `None` if any tap shows a surface in front of it
/// (hidden), or if too little of the taps is its surface or the person.
fn sample_surface(
    f: &Fragments,
    source: &SourceImage,
    at: Vec3,
    triangle: i32,
    compartment: &[u8],
    camera: &Camera,
) -> Option<([f32; 3], f32)> {
    let (x, y, z) = (at.x, at.y, at.z);
    let tolerance = DEPTH_TOLERANCE_PIXELS * camera.pixel_footprint(z);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let (mut rgb, mut mask, mut weight) = ([0.0f32; 3], 0.0f32, 0.0f32);
    for (px, py, w) in [
        (x0, y0, (1.0 - fx) * (1.0 - fy)),
        (x0 + 1, y0, fx * (1.0 - fy)),
        (x0, y0 + 1, (1.0 - fx) * fy),
        (x0 + 1, y0 + 1, fx * fy),
    ] {
        if w == 0.0 || px < 0 || py < 0 || px >= f.width as i64 || py >= f.height as i64 {
            continue;
        }
        let k = f.index(px as u32, py as u32);
        let front = f.triangle[k];
        let same_side = front >= 0 && compartment[front as usize] == compartment[triangle as usize];
        let near = if same_side { tolerance } else { 0.0 };
        let own = front == triangle || (same_side && (f.depth[k] - z).abs() <= tolerance);
        if !own {
            if f.depth[k] < z - near {
                return None;
            }
            // A farther surface (or the background) behind the silhouette: not this texel's.
            continue;
        }
        let (c, m) = source.pixel(k);
        for (acc, v) in rgb.iter_mut().zip(c) {
            *acc += w * v;
        }
        mask += w * m;
        weight += w;
    }
    if weight < MIN_OWN_WEIGHT || mask < MIN_MASK * weight {
        return None;
    }
    // The photo is premultiplied by its mask; divide it back out at the silhouette.
    Some((rgb.map(|c| (c / mask).min(1.0)), (mask / weight).min(1.0)))
}
