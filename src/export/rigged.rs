//! An avatar as a rigged glTF 2.0 file other tools can animate (`guava export`):
//! - the body as a skinned mesh in the avatar's identity at rest (its bind pose): the skeleton's
//!   joints as nodes (world-aligned rest frames, so each joint's inverse bind matrix is a
//!   translation), the body's eight skinning influences as `JOINTS_0/1`, `WEIGHTS_0/1`, its UVs
//!   and a colour texture baked from the avatar's UV Gaussians, its expression units (ARKit's
//!   names on the default body) as morph targets;
//! - the avatar's Gaussians as a point primitive under `KHR_gaussian_splatting` (the Khronos
//!   review draft of 2025: position, rotation xyzw, log scale, opacity, degree-0 SH, and
//!   `COLOR_0` for viewers that draw points), at the bind pose, each bound to the skeleton by
//!   its anchors' blended skinning weights, so a viewer that skins splats can animate them;
//! - a motion as one animation clip: every joint's rotation, the root's translation and the
//!   morph weights, keyed at the motion's frames.
//!
//! The mesh at a key matches [`BodyModel::pose`] exactly (the same linear blend skinning). The
//! splats only approximately match the project's own rig, which glTF cannot express: UV
//! Gaussians ride their triangle's frame and the clothing layer moves along posed normals, where
//! glTF skins each point by blended weights (`tests/export_gltf.rs` measures how far).

use std::path::Path;

use glam::{Mat4, Vec3};
use serde_json::{Value, json};

use super::glb::{ARRAY_BUFFER, Glb, Kind};
use crate::avatar::{Avatar, HandsInView, Rig, quat_from_matrix};
use crate::body::{BodyModel, BodyPose, MAX_INFLUENCES, MorphTarget, PosedBody, TargetGroup};
use crate::gaussians::GaussianCloud;
use crate::tracking::{Retarget, Tracking};

/// The baked texture's side, in pixels (the UV map has 448² texels).
pub const TEXTURE_SIZE: u32 = 512;
/// The degree-0 spherical harmonic's constant: colour = 0.5 + C0 · SH0.
const SH_C0: f32 = 0.282_094_8;

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("{0}")]
    Body(String),
    #[error("posing the body: {0}")]
    Pose(#[from] crate::body::PoseError),
    #[error("rigging the avatar: {0}")]
    Rig(#[from] crate::avatar::BodyMismatch),
    #[error("encoding the texture: {0}")]
    Texture(#[from] image::ImageError),
    #[error("writing {path}: {source}")]
    Write {
        path: String,
        source: std::io::Error,
    },
    #[error("cancelled")]
    Cancelled,
}

/// What was written.
#[derive(Clone, Debug, PartialEq)]
pub struct Exported {
    pub joints: usize,
    pub vertices: usize,
    pub morph_targets: usize,
    pub splats: usize,
    /// Keyframes of the animation clip (0 without a motion).
    pub frames: usize,
    pub bytes: u64,
}

/// The avatar's bind pose on `body`: the rest pose in its identity.
pub fn bind_pose(avatar: &Avatar, body: &BodyModel) -> BodyPose {
    let mut pose = BodyPose::rest(body);
    avatar.apply_identity(body, &mut pose);
    pose
}

/// The pose of the animation's frame at `time`: the motion over the avatar's base pose (as
/// `guava render --motion` poses it), in its identity.
pub fn motion_pose(
    avatar: &Avatar,
    body: &BodyModel,
    motion: &Tracking,
    retarget: &Retarget,
    time: f64,
) -> BodyPose {
    let mut pose = avatar.base_pose(body);
    retarget.sample(motion, time, &mut pose);
    avatar.apply_identity(body, &mut pose);
    pose
}

/// The body's morph targets the file carries: those a motion or a user moves (not the
/// identity, which is baked into the bind pose). Nine of the default body's face units also
/// move the eyes' or the jaw's rest position a little, which glTF's morph targets cannot; a
/// joint's rest position changes nothing while the joint itself is not turned, and the face is
/// posed by these units, not by turning the jaw (the test measures the mesh within 1e-5 m).
pub fn exported_targets(avatar: &Avatar, body: &BodyModel) -> Vec<usize> {
    (0..body.targets.len())
        .filter(|&i| {
            let t = &body.targets[i];
            t.group != TargetGroup::Shape && !avatar.identity.contains_key(&t.name)
        })
        .collect()
}

/// Writes `avatar` on `body` to `path` as a binary glTF, with `motion` as its animation when
/// given. `progress` hears the share done and cancels by returning false; the file is written
/// whole or not at all.
pub fn export(
    avatar: &Avatar,
    body: &BodyModel,
    motion: Option<&Tracking>,
    path: &Path,
    progress: &mut dyn FnMut(f32) -> bool,
) -> Result<Exported, ExportError> {
    avatar.check_body(body).map_err(ExportError::Body)?;
    let mut step = |done: f32| progress(done).then_some(()).ok_or(ExportError::Cancelled);
    let mut bind = PosedBody::default();
    body.pose(&bind_pose(avatar, body), &mut bind)?;
    let targets = exported_targets(avatar, body);
    let joint_count = body.joints.len();
    let (mesh_node, splat_node) = (joint_count, joint_count + 1);
    let mut glb = Glb::default();

    // The skeleton: one node per joint, its rest offset from its parent.
    let mut nodes: Vec<Value> = body
        .joints
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let offset = match joint.parent {
                Some(p) => bind.rest_joints[j] - bind.rest_joints[p],
                None => bind.rest_joints[j],
            };
            json!({"name": joint.name, "translation": offset.to_array()})
        })
        .collect();
    for (j, joint) in body.joints.iter().enumerate() {
        if let Some(p) = joint.parent {
            let children = nodes[p]
                .as_object_mut()
                .expect("node")
                .entry("children")
                .or_insert_with(|| json!([]));
            children.as_array_mut().expect("children").push(json!(j));
        }
    }
    let inverse_binds: Vec<f32> = bind
        .rest_joints
        .iter()
        .flat_map(|&p| Mat4::from_translation(-p).to_cols_array())
        .collect();
    let inverse_binds = glb.floats(&inverse_binds, Kind::Mat4, None, false);
    let roots: Vec<usize> = (0..joint_count)
        .filter(|&j| body.joints[j].parent.is_none())
        .collect();
    step(0.1)?;

    // The body mesh.
    let normals = body.normals_of(&bind.vertices);
    let flat = |v: &[Vec3]| v.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>();
    let position = glb.floats(&flat(&bind.vertices), Kind::Vec3, Some(ARRAY_BUFFER), true);
    let normal = glb.floats(&flat(&normals), Kind::Vec3, Some(ARRAY_BUFFER), false);
    let uvs: Vec<f32> = body.uvs.iter().flat_map(|u| u.to_array()).collect();
    let uv = glb.floats(&uvs, Kind::Vec2, Some(ARRAY_BUFFER), false);
    let influences: Vec<Vec<(u16, f32)>> = body
        .skin_joints
        .iter()
        .zip(&body.skin_weights)
        .map(|(j, w)| j.iter().copied().zip(w.iter().copied()).collect())
        .collect();
    let mut attributes = skin_attributes(&mut glb, &influences);
    attributes.insert("POSITION".into(), json!(position));
    attributes.insert("NORMAL".into(), json!(normal));
    attributes.insert("TEXCOORD_0".into(), json!(uv));
    let morphs: Vec<Value> = targets
        .iter()
        .map(|&t| {
            let target = &body.targets[t];
            let mut moved: Vec<(u32, [f32; 3])> = target
                .vertices
                .iter()
                .zip(&target.deltas)
                .map(|(&v, d)| (v, d.to_array()))
                .collect();
            moved.sort_by_key(|&(v, _)| v);
            moved.dedup_by_key(|&mut (v, _)| v);
            let (indices, values): (Vec<u32>, Vec<[f32; 3]>) = moved.into_iter().unzip();
            json!({"POSITION": glb.sparse_vec3(bind.vertices.len(), &indices, &values)})
        })
        .collect();
    let indices = glb.indices(&body.triangles);
    let texture = bake_texture(avatar, body)?;
    let image_view = glb.view(&texture, None);
    let target_names: Vec<&str> = targets
        .iter()
        .map(|&t| body.targets[t].name.as_str())
        .collect();
    let body_mesh = json!({
        "name": "body",
        "primitives": [{
            "attributes": attributes,
            "indices": indices,
            "material": 0,
            "mode": 4,
            "targets": morphs,
        }],
        "weights": vec![0.0; targets.len()],
        "extras": {"targetNames": target_names},
    });
    step(0.4)?;

    // The splats at the bind pose, skinned by their anchors' weights. Hands the photo did not
    // show are transparent there, as the viewer draws them below the bust; glTF cannot switch
    // them on where a pose raises them into the photo's view.
    let mut cloud = GaussianCloud::new(avatar.channels);
    let hands = HandsInView::new(avatar, body).map(std::sync::Arc::new);
    Rig::with_hands(hands).animate(avatar, &bind, body, &mut cloud)?;
    let anchors = splat_anchors(avatar, body);
    let splat_influences = splat_influences(&anchors, &influences);
    let splat_morphs: Vec<Value> = targets
        .iter()
        .map(|&t| json!({"POSITION": splat_morph(&mut glb, &body.targets[t], &anchors, body.vertices.len())}))
        .collect();
    let mut splat_mesh = splat_primitive(
        &mut glb,
        &cloud,
        &splat_influences,
        splat_morphs,
        targets.len(),
    );
    splat_mesh["extras"] = json!({"targetNames": target_names});
    step(0.6)?;

    let mut json = json!({
        "asset": {"version": "2.0", "generator": "guava-rs (guava export)"},
        "extensionsUsed": ["KHR_gaussian_splatting", "KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{"nodes": roots.iter().copied().chain([mesh_node, splat_node]).collect::<Vec<_>>()}],
        "skins": [{"joints": (0..joint_count).collect::<Vec<_>>(), "inverseBindMatrices": inverse_binds, "skeleton": roots[0]}],
        "meshes": [body_mesh, splat_mesh],
        "materials": [{
            "name": "avatar",
            "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_unlit": {}},
        }],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071}],
        "images": [{"bufferView": image_view, "mimeType": "image/png"}],
    });
    nodes.push(json!({"name": "body", "mesh": 0, "skin": 0}));
    nodes.push(json!({"name": "avatar splats", "mesh": 1, "skin": 0}));
    json["nodes"] = Value::Array(nodes);

    let mut frames = 0;
    if let Some(motion) = motion {
        let retarget = Retarget::new(motion, body);
        let times = crate::render::sequence::frame_times(motion.duration(), motion.fps);
        let poses: Vec<BodyPose> = times
            .iter()
            .map(|&t| motion_pose(avatar, body, motion, &retarget, t))
            .collect();
        frames = poses.len();
        json["animations"] = json!([animation(
            &mut glb, body, &bind, &targets, &times, &poses, mesh_node
        )]);
    }
    step(0.9)?;
    glb.write(path, json).map_err(|source| ExportError::Write {
        path: path.display().to_string(),
        source,
    })?;
    step(1.0)?;
    Ok(Exported {
        joints: joint_count,
        vertices: bind.vertices.len(),
        morph_targets: targets.len(),
        splats: cloud.positions.len(),
        frames,
        bytes: std::fs::metadata(path).map_or(0, |m| m.len()),
    })
}

/// `JOINTS_0/1` and `WEIGHTS_0/1` of points each skinned by up to [`MAX_INFLUENCES`] of
/// `influences`.
fn skin_attributes(
    glb: &mut Glb,
    influences: &[Vec<(u16, f32)>],
) -> serde_json::Map<String, Value> {
    let mut attributes = serde_json::Map::new();
    for set in 0..MAX_INFLUENCES / 4 {
        let mut joints = Vec::with_capacity(influences.len());
        let mut weights = Vec::with_capacity(influences.len() * 4);
        for point in influences {
            let j = std::array::from_fn(|slot| {
                let (joint, weight) = point.get(4 * set + slot).copied().unwrap_or((0, 0.0));
                weights.push(weight.max(0.0));
                // A joint with no weight is written as joint 0, as validators expect.
                if weight > 0.0 { joint as u8 } else { 0 }
            });
            joints.push(j);
        }
        attributes.insert(format!("JOINTS_{set}"), json!(glb.joints(&joints)));
        let w = glb.floats(&weights, Kind::Vec4, Some(ARRAY_BUFFER), false);
        attributes.insert(format!("WEIGHTS_{set}"), json!(w));
    }
    attributes
}

/// The body vertices each Gaussian the rig draws hangs on, with their shares, in its order
/// (template: its vertex; beyond the body: its anchors by weight; the shown UV Gaussians: their
/// triangle's corners by barycentrics).
pub fn splat_anchors(avatar: &Avatar, body: &BodyModel) -> Vec<Vec<(usize, f32)>> {
    let mut out: Vec<Vec<(usize, f32)>> =
        (0..body.vertices.len()).map(|v| vec![(v, 1.0)]).collect();
    let k = &avatar.skinned;
    for (v, w) in k.vertices.iter().zip(&k.weights) {
        out.push(v.iter().zip(w).map(|(&v, &w)| (v as usize, w)).collect());
    }
    let uv = &avatar.uv;
    for (&f, b) in uv
        .triangles
        .iter()
        .zip(&uv.barycentrics)
        .take(avatar.shown_uv(false))
    {
        let corners = body.triangles[f as usize];
        out.push(
            corners
                .iter()
                .zip(b)
                .map(|(&v, &b)| (v as usize, b))
                .collect(),
        );
    }
    out
}

/// Each Gaussian's skinning: its anchors' influences blended by their shares (the strongest
/// [`MAX_INFLUENCES`], renormalised).
pub fn splat_influences(
    anchors: &[Vec<(usize, f32)>],
    vertex: &[Vec<(u16, f32)>],
) -> Vec<Vec<(u16, f32)>> {
    anchors
        .iter()
        .map(|anchor| {
            let mut sum: Vec<(u16, f32)> = Vec::new();
            for &(v, a) in anchor {
                for &(j, w) in &vertex[v] {
                    match sum.iter_mut().find(|(k, _)| *k == j) {
                        Some((_, total)) => *total += a * w,
                        None => sum.push((j, a * w)),
                    }
                }
            }
            sum.retain(|&(_, w)| w > 0.0);
            sum.sort_by(|a, b| b.1.total_cmp(&a.1));
            sum.truncate(MAX_INFLUENCES);
            let total: f32 = sum.iter().map(|&(_, w)| w).sum();
            sum.iter_mut().for_each(|(_, w)| *w /= total);
            sum
        })
        .collect()
}

/// A morph target's deltas carried onto the Gaussians by their anchors' shares, as a sparse
/// accessor (the face's units move a few thousand of them).
fn splat_morph(
    glb: &mut Glb,
    target: &MorphTarget,
    anchors: &[Vec<(usize, f32)>],
    vertices: usize,
) -> usize {
    let mut delta = vec![None; vertices];
    for (&v, &d) in target.vertices.iter().zip(&target.deltas) {
        delta[v as usize] = Some(d);
    }
    let (mut indices, mut values) = (Vec::new(), Vec::new());
    for (i, anchor) in anchors.iter().enumerate() {
        let moved: Vec<Vec3> = anchor
            .iter()
            .filter_map(|&(v, a)| delta[v].map(|d| a * d))
            .collect();
        if !moved.is_empty() {
            indices.push(i as u32);
            values.push(moved.into_iter().sum::<Vec3>().to_array());
        }
    }
    glb.sparse_vec3(anchors.len(), &indices, &values)
}

/// The splats as a `KHR_gaussian_splatting` point primitive's mesh.
fn splat_primitive(
    glb: &mut Glb,
    cloud: &GaussianCloud,
    influences: &[Vec<(u16, f32)>],
    morphs: Vec<Value>,
    targets: usize,
) -> Value {
    let n = cloud.positions.len();
    let c = cloud.channels;
    let rgb = |i: usize| [0, 1, 2].map(|k| cloud.features[i * c + k.min(c - 1)]);
    let positions: Vec<f32> = cloud.positions.as_flattened().to_vec();
    let rotations: Vec<f32> = cloud
        .rotations
        .iter()
        .flat_map(|q| {
            let len = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
                .sqrt()
                .max(1e-12);
            [q[1] / len, q[2] / len, q[3] / len, q[0] / len]
        })
        .collect();
    let scales: Vec<f32> = cloud
        .scales
        .iter()
        .flat_map(|s| s.map(|v| v.max(1e-12).ln()))
        .collect();
    let sh: Vec<f32> = (0..n)
        .flat_map(|i| rgb(i).map(|v| (v - 0.5) / SH_C0))
        .collect();
    let colours: Vec<f32> = (0..n)
        .flat_map(|i| {
            let [r, g, b] = rgb(i).map(|v| v.clamp(0.0, 1.0));
            [r, g, b, cloud.opacities[i].clamp(0.0, 1.0)]
        })
        .collect();
    let opacities: Vec<f32> = cloud.opacities.iter().map(|o| o.clamp(0.0, 1.0)).collect();
    let mut attributes = skin_attributes(glb, influences);
    for (name, data, kind) in [
        ("POSITION", &positions, Kind::Vec3),
        ("COLOR_0", &colours, Kind::Vec4),
        ("KHR_gaussian_splatting:ROTATION", &rotations, Kind::Vec4),
        ("KHR_gaussian_splatting:SCALE", &scales, Kind::Vec3),
        ("KHR_gaussian_splatting:OPACITY", &opacities, Kind::Scalar),
        ("KHR_gaussian_splatting:SH_DEGREE_0_COEF_0", &sh, Kind::Vec3),
    ] {
        // Positions carry the bounds glTF requires of them.
        let id = glb.floats(data, kind, Some(ARRAY_BUFFER), name == "POSITION");
        attributes.insert(name.into(), json!(id));
    }
    json!({
        "name": "avatar splats",
        "primitives": [{
            "attributes": attributes,
            "mode": 0,
            "targets": morphs,
            "extensions": {"KHR_gaussian_splatting": {
                "kernel": "ellipse",
                "colorSpace": "srgb_rec709_display",
                "sortingMethod": "cameraDistance",
                "projection": "perspective",
            }},
        }],
        "weights": vec![0.0; targets],
    })
}

/// One clip of `poses` at `times`: every joint's rotation, the roots' translation and the morph
/// weights of the body's and the splats' nodes (`mesh_node` and the next).
fn animation(
    glb: &mut Glb,
    body: &BodyModel,
    bind: &PosedBody,
    targets: &[usize],
    times: &[f64],
    poses: &[BodyPose],
    mesh_node: usize,
) -> Value {
    let input: Vec<f32> = times.iter().map(|&t| t as f32).collect();
    let input = glb.floats(&input, Kind::Scalar, None, true);
    let (mut samplers, mut channels) = (Vec::new(), Vec::new());
    let mut channel = |glb: &mut Glb, node: usize, path: &str, values: Vec<f32>, kind: Kind| {
        let output = glb.floats(&values, kind, None, false);
        samplers.push(json!({"input": input, "output": output, "interpolation": "LINEAR"}));
        channels
            .push(json!({"sampler": samplers.len() - 1, "target": {"node": node, "path": path}}));
    };
    let mut nonfinite = 0;
    for j in 0..body.joints.len() {
        let rotations: Vec<f32> = poses
            .iter()
            .flat_map(|p| {
                let q = quat_from_matrix(crate::body::rodrigues(p.rotations[j], &mut nonfinite));
                [q[1], q[2], q[3], q[0]]
            })
            .collect();
        channel(glb, j, "rotation", rotations, Kind::Vec4);
        if body.joints[j].parent.is_none() {
            let moved: Vec<f32> = poses
                .iter()
                .flat_map(|p| (bind.rest_joints[j] + p.translation).to_array())
                .collect();
            channel(glb, j, "translation", moved, Kind::Vec3);
        }
    }
    if !targets.is_empty() {
        let weights: Vec<f32> = poses
            .iter()
            .flat_map(|p| targets.iter().map(|&t| p.coefficients[t]))
            .collect();
        channel(glb, mesh_node, "weights", weights.clone(), Kind::Scalar);
        channel(glb, mesh_node + 1, "weights", weights, Kind::Scalar);
    }
    json!({"name": "motion", "samplers": samplers, "channels": channels})
}

/// The avatar's colours on the body's UV layout: each shown UV Gaussian's RGB at its UV (the
/// mean where several fall in one pixel), the gaps filled from their neighbours, as a PNG.
pub fn bake_texture(avatar: &Avatar, body: &BodyModel) -> Result<Vec<u8>, image::ImageError> {
    let size = TEXTURE_SIZE as usize;
    let mut sum = vec![[0.0f32; 4]; size * size];
    let uv = &avatar.uv;
    let c = avatar.channels;
    for (i, (&f, b)) in uv
        .triangles
        .iter()
        .zip(&uv.barycentrics)
        .take(avatar.shown_uv(false))
        .enumerate()
    {
        let corners = body.triangles[f as usize];
        let at: glam::Vec2 = (0..3).map(|k| b[k] * body.uvs[corners[k] as usize]).sum();
        let (x, y) = ((at.x * size as f32) as usize, (at.y * size as f32) as usize);
        if x < size && y < size {
            let cell = &mut sum[y * size + x];
            for (k, total) in cell.iter_mut().take(3).enumerate() {
                *total += uv.local.features[i * c + k.min(c - 1)];
            }
            cell[3] += 1.0;
        }
    }
    fill_gaps(&mut sum, size);
    let quantize = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    let pixels = image::RgbImage::from_fn(TEXTURE_SIZE, TEXTURE_SIZE, |x, y| {
        let cell = sum[y as usize * size + x as usize];
        image::Rgb([0, 1, 2].map(|k| quantize(cell[k] / cell[3].max(1e-6))))
    });
    let mut png = Vec::new();
    pixels.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    Ok(png)
}

/// Grows filled cells (count in `[3]`) into empty ones, a ring at a time, so that texture
/// filtering and mipmaps at UV seams read the avatar's colours, not black.
fn fill_gaps(cells: &mut [[f32; 4]], size: usize) {
    for _ in 0..size {
        let empty: Vec<usize> = (0..cells.len()).filter(|&i| cells[i][3] == 0.0).collect();
        if empty.is_empty() {
            return;
        }
        let mut grown = Vec::new();
        for &i in &empty {
            let (x, y) = ((i % size) as i64, (i / size) as i64);
            let mut cell = [0.0f32; 4];
            for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
                let (nx, ny) = (x + dx, y + dy);
                if (0..size as i64).contains(&nx) && (0..size as i64).contains(&ny) {
                    let n = cells[ny as usize * size + nx as usize];
                    if n[3] > 0.0 {
                        for k in 0..3 {
                            cell[k] += n[k] / n[3];
                        }
                        cell[3] += 1.0;
                    }
                }
            }
            if cell[3] > 0.0 {
                grown.push((i, cell));
            }
        }
        if grown.is_empty() {
            return;
        }
        for (i, cell) in grown {
            cells[i] = cell;
        }
    }
}
