//! The body's UV map as a grid of texels: which triangle each texel lies on and where
//! (barycentrics), and, for a left–right symmetric mesh, the texel at the mirrored surface point.
//!
//! Texel (row r, column c) of an S×S map is the UV point ((c + ½)/S, (r + ½)/S), glTF's convention
//! (v = 0 is the top row). A texel belongs to the triangle whose UV footprint contains its centre;
//! where UV islands overlap the later triangle wins, as in the reference's `cv2.drawContours` fill.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use crate::body::BodyModel;
use crate::raster::cover;

#[derive(Clone, Debug, PartialEq)]
pub struct UvMap {
    pub size: u32,
    /// Per texel, row-major: the triangle it lies on, or −1.
    pub triangle: Vec<i32>,
    pub bary: Vec<[f32; 3]>,
    /// The valid texels' indices, row-major: the order of the UV Gaussians.
    pub texels: Vec<u32>,
    /// Per texel: the texel at the mirror image (x → −x) of its surface point, or −1 where the mesh
    /// has no mirrored triangle.
    pub mirror: Vec<i32>,
}

impl UvMap {
    /// Rasterizes the UV layout of `uvs`/`triangles` at `size`² texels (no mirror map).
    pub fn new(uvs: &[Vec2], triangles: &[[u32; 3]], size: u32) -> Self {
        let s = size as usize;
        let mut triangle = vec![-1; s * s];
        let mut bary = vec![[0.0; 3]; s * s];
        for (t, tri) in triangles.iter().enumerate() {
            let corners = tri.map(|i| uvs[i as usize] * size as f32);
            cover(corners, size, size, |c, r, l| {
                let i = r as usize * s + c as usize;
                triangle[i] = t as i32;
                bary[i] = l;
            });
        }
        let texels = (0..(s * s) as u32)
            .filter(|&i| triangle[i as usize] >= 0)
            .collect();
        Self {
            size,
            triangle,
            bary,
            texels,
            mirror: vec![-1; s * s],
        }
    }

    /// The body's UV map with its mirror map (from the rest mesh's left–right symmetry).
    pub fn for_body(body: &BodyModel, size: u32) -> Self {
        let mut map = Self::new(&body.uvs, &body.triangles, size);
        let mirrored = mirror_triangles(body);
        let s = size as f32;
        for &texel in &map.texels {
            let i = texel as usize;
            let Some((t, corners)) = mirrored[map.triangle[i] as usize] else {
                continue;
            };
            let tri = body.triangles[t];
            let b = map.bary[i];
            let uv: Vec2 = (0..3)
                .map(|k| b[k] * body.uvs[tri[corners[k]] as usize])
                .sum();
            let (c, r) = ((uv.x * s).floor(), (uv.y * s).floor());
            if (0.0..s).contains(&c) && (0.0..s).contains(&r) {
                let m = r as usize * size as usize + c as usize;
                if map.triangle[m] >= 0 {
                    map.mirror[i] = m as i32;
                }
            }
        }
        map
    }

    pub fn len(&self) -> usize {
        self.texels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.texels.is_empty()
    }

    /// The surface point of texel `i` on a (posed) copy of the mesh.
    pub fn point(&self, i: usize, vertices: &[Vec3], triangles: &[[u32; 3]]) -> Vec3 {
        let tri = triangles[self.triangle[i] as usize];
        let b = self.bary[i];
        b[0] * vertices[tri[0] as usize]
            + b[1] * vertices[tri[1] as usize]
            + b[2] * vertices[tri[2] as usize]
    }

    /// The corner of texel `i`'s triangle nearest it (largest barycentric): the vertex whose
    /// labels (body part) the texel takes.
    pub fn nearest_vertex(&self, i: usize, triangles: &[[u32; 3]]) -> usize {
        let b = self.bary[i];
        let k = (0..3).fold(0, |m, k| if b[k] > b[m] { k } else { m });
        triangles[self.triangle[i] as usize][k] as usize
    }
}

/// Positions closer than this (metres) are the same point for the mirror match.
const MIRROR_TOLERANCE: f32 = 1e-4;

/// For each triangle, the triangle at its mirror image and which of its corners each corner maps
/// to; `None` where the mesh is not symmetric there. Matching goes through the weld map, so UV
/// seams (split vertices at one position) do not confuse it.
fn mirror_triangles(body: &BodyModel) -> Vec<Option<(usize, [usize; 3])>> {
    let cell = |p: Vec3| (p / MIRROR_TOLERANCE).round().as_ivec3();
    let weld_count = body.weld.iter().max().map_or(0, |&m| m as usize + 1);
    let mut weld_pos = vec![Vec3::NAN; weld_count];
    for (v, &w) in body.weld.iter().enumerate() {
        weld_pos[w as usize] = body.vertices[v];
    }
    let grid: HashMap<glam::IVec3, u32> = weld_pos
        .iter()
        .enumerate()
        .filter(|(_, p)| p.is_finite())
        .map(|(w, &p)| (cell(p), w as u32))
        .collect();
    let find = |p: Vec3| -> Option<u32> {
        let c = cell(p);
        (-1..=1)
            .flat_map(|dx| (-1..=1).flat_map(move |dy| (-1..=1).map(move |dz| (dx, dy, dz))))
            .filter_map(|(dx, dy, dz)| grid.get(&(c + glam::IVec3::new(dx, dy, dz))))
            .copied()
            .find(|&w| weld_pos[w as usize].distance(p) <= MIRROR_TOLERANCE)
    };
    let mirror_weld: Vec<Option<u32>> = weld_pos
        .iter()
        .map(|&p| find(Vec3::new(-p.x, p.y, p.z)))
        .collect();
    let welds = |tri: &[u32; 3]| tri.map(|v| body.weld[v as usize]);
    let sorted = |mut k: [u32; 3]| {
        k.sort_unstable();
        k
    };
    let by_welds: HashMap<[u32; 3], usize> = body
        .triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| (sorted(welds(tri)), t))
        .collect();
    body.triangles
        .iter()
        .map(|tri| {
            let m = welds(tri).map(|w| mirror_weld[w as usize]);
            let m = [m[0]?, m[1]?, m[2]?];
            let t = *by_welds.get(&sorted(m))?;
            let other = welds(&body.triangles[t]);
            let corner = |w: u32| other.iter().position(|&o| o == w);
            Some((t, [corner(m[0])?, corner(m[1])?, corner(m[2])?]))
        })
        .collect()
}
