//! Reading and validating the converted EHM model (`tools/convert_ehm.py`). Every problem is one
//! error naming the file and the array.

use std::path::Path;

use glam::{Vec2, Vec3};

use super::{EhmIdentity, EhmModel, ReferenceTexels, Skinned};
use crate::body::SMPLX_JOINTS;
use crate::npz::{Npz, NpzError};

/// The `format` string the converter writes; bumped when the layout changes.
pub const EHM_FORMAT: &str = "guava-rs ehm 1";
const HAND_VERTICES: usize = 778;
const FLAME_JOINTS: usize = 5;
/// Skin weights of a vertex must sum to 1 within this (float32 storage of normalised weights).
const WEIGHT_SUM_TOLERANCE: f32 = 1e-3;

impl EhmModel {
    pub fn load(path: &Path) -> Result<Self, NpzError> {
        Self::from_opened(&Npz::open(path)?, path)
    }

    /// From an `.npz` already opened from `path`; the model is named after the file's stem.
    pub fn from_opened(npz: &Npz, path: &Path) -> Result<Self, NpzError> {
        let name = path
            .file_stem()
            .map_or_else(|| "EHM".into(), |s| s.to_string_lossy().into_owned());
        Self::from_npz(npz, name)
    }

    pub fn from_npz(npz: &Npz, name: String) -> Result<Self, NpzError> {
        let format = npz.string("format")?;
        if format != EHM_FORMAT {
            return Err(npz.error(format!(
                "format is {format:?}, this build reads {EHM_FORMAT:?} (re-run tools/convert_ehm.py)"
            )));
        }
        let count = |name: &str| -> Result<usize, NpzError> {
            let (v, _) = npz.indices(name, &[Some(1)], 0..10_000)?;
            Ok(v[0] as usize)
        };
        let (n_shape, n_exp) = (count("n_shape")?, count("n_exp")?);

        let body = skinned(npz, "smplx", SMPLX_JOINTS.len(), n_shape + n_exp)?;
        let vertex_count = body.template.len();
        let head = skinned(npz, "flame", FLAME_JOINTS, n_shape + n_exp)?;
        let head_count = head.template.len();

        let (texcoords, t_shape) = npz.f32s("smplx_texcoords", &[None, Some(2)])?;
        let triangles = triples(npz, "smplx_faces", vertex_count)?;
        let triangle_uvs = triples(npz, "smplx_faces_uv", t_shape[0])?;
        if triangle_uvs.len() != triangles.len() {
            return Err(npz.error(format!(
                "smplx_faces_uv: {} triangles for {} faces",
                triangle_uvs.len(),
                triangles.len()
            )));
        }
        let triangle_count = triangles.len();
        let ids = |name: &str, len: usize, bound: usize| -> Result<Vec<u32>, NpzError> {
            let (v, _) = npz.indices(name, &[Some(len)], 0..bound as i64)?;
            Ok(v.iter().map(|&i| i as u32).collect())
        };
        let centre = |name: &str| -> Result<Vec3, NpzError> {
            Ok(Vec3::from_slice(npz.f32s(name, &[Some(3)])?.0))
        };
        let eyelid = |name: &str| -> Result<Vec<Vec3>, NpzError> {
            Ok(vec3s(npz.f32s(name, &[Some(head_count), Some(3)])?.0))
        };
        Ok(Self {
            name,
            n_shape,
            n_exp,
            triangles,
            triangle_uvs,
            texcoords: texcoords.chunks_exact(2).map(Vec2::from_slice).collect(),
            head_vertices: ids("smplx_to_flame", head_count, vertex_count)?,
            hands: [
                ids("left_hand", HAND_VERTICES, vertex_count)?,
                ids("right_hand", HAND_VERTICES, vertex_count)?,
            ],
            hand_centres: [centre("left_hand_center")?, centre("right_hand_center")?],
            eyelids: [eyelid("flame_l_eyelid")?, eyelid("flame_r_eyelid")?],
            identity: EhmIdentity::default(),
            reference_texels: reference_texels(npz, triangle_count)?,
            parameter_names: Self::make_parameter_names(n_shape, n_exp),
            shape_caches: Default::default(),
            body,
            head,
        })
    }
}

/// The optional `uv_texel_face` / `uv_texel_bary` pair (older files have neither).
fn reference_texels(npz: &Npz, triangles: usize) -> Result<Option<ReferenceTexels>, NpzError> {
    if !npz.contains("uv_texel_face") && !npz.contains("uv_texel_bary") {
        return Ok(None);
    }
    let (face, shape) = npz.indices("uv_texel_face", &[None, None], -1..triangles as i64)?;
    let size = shape[0];
    if shape[1] != size {
        return Err(npz.error(format!(
            "uv_texel_face: shape {shape:?}, expected a square map"
        )));
    }
    let (bary, _) = npz.f32s("uv_texel_bary", &[Some(size), Some(size), Some(3)])?;
    Ok(Some(ReferenceTexels {
        size: size as u32,
        triangle: face.iter().map(|&f| f as i32).collect(),
        bary: bary.chunks_exact(3).map(|b| [b[0], b[1], b[2]]).collect(),
    }))
}

fn vec3s(data: &[f32]) -> Vec<Vec3> {
    data.chunks_exact(3).map(Vec3::from_slice).collect()
}

fn triples(npz: &Npz, name: &str, bound: usize) -> Result<Vec<[u32; 3]>, NpzError> {
    let (v, _) = npz.indices(name, &[None, Some(3)], 0..bound as i64)?;
    Ok(v.chunks_exact(3)
        .map(|t| [t[0] as u32, t[1] as u32, t[2] as u32])
        .collect())
}

/// One of the two meshes (`prefix` smplx or flame), checked for consistent sizes, a parent order
/// with parents first, and skin weights summing to 1; dense arrays become sparse where they are.
fn skinned(npz: &Npz, prefix: &str, joints: usize, components: usize) -> Result<Skinned, NpzError> {
    let key = |s: &str| format!("{prefix}_{s}");
    let (template, shape) = npz.f32s(&key("v_template"), &[None, Some(3)])?;
    let v = shape[0];
    let (dirs, _) = npz.f32s(&key("shapedirs"), &[Some(v), Some(3), Some(components)])?;
    let mut shape_dirs = vec![Vec::with_capacity(v * 3); components];
    for per_coordinate in dirs.chunks_exact(components) {
        for (dir, &d) in shape_dirs.iter_mut().zip(per_coordinate) {
            dir.push(d);
        }
    }
    let (pose, _) = npz.f32s(&key("posedirs"), &[Some((joints - 1) * 9), Some(v * 3)])?;
    let pose_dirs = pose.chunks_exact(v * 3).map(<[f32]>::to_vec).collect();

    let (regressor, _) = npz.f32s(&key("j_regressor"), &[Some(joints), Some(v)])?;
    let regressor = regressor
        .chunks_exact(v)
        .map(|row| sparse(row).map(|(i, w)| (i as u32, w)).collect())
        .collect();

    let (parents, _) = npz.indices(&key("parents"), &[Some(joints)], -1..joints as i64)?;
    let parents: Vec<Option<usize>> = parents.iter().map(|&p| usize::try_from(p).ok()).collect();
    if let Some(j) = (0..joints).find(|&j| (j == 0) != parents[j].is_none_or(|p| p >= j)) {
        return Err(npz.error(format!(
            "{}: joint {j} has parent {:?}; the root must be -1 and every other parent must precede its joint",
            key("parents"),
            parents[j]
        )));
    }

    let (weights, _) = npz.f32s(&key("weights"), &[Some(v), Some(joints)])?;
    let weights: Vec<Vec<(u16, f32)>> = weights
        .chunks_exact(joints)
        .map(|row| sparse(row).map(|(j, w)| (j as u16, w)).collect())
        .collect();
    if let Some((i, sum)) = weights
        .iter()
        .map(|w| w.iter().map(|&(_, w)| w).sum::<f32>())
        .enumerate()
        .find(|(_, s)| (s - 1.0).abs() > WEIGHT_SUM_TOLERANCE)
    {
        return Err(npz.error(format!(
            "{}: weights of vertex {i} sum to {sum}, not 1",
            key("weights")
        )));
    }
    Ok(Skinned {
        template: vec3s(template),
        shape_dirs,
        pose_dirs,
        regressor,
        parents,
        weights,
    })
}

fn sparse(row: &[f32]) -> impl Iterator<Item = (usize, f32)> + '_ {
    row.iter().copied().enumerate().filter(|&(_, w)| w != 0.0)
}
