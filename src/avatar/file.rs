//! The avatar file (`.guava`): a JSON header line and the arrays as little-endian f32/u32, so a
//! saved avatar loads back bit for bit. Written through a temporary file and renamed into place.
//!
//! Layout: `guava-rs avatar 2\n`, the header (one line of JSON), `\n`, then the template arrays
//! (rotations 4, scales 3, opacities 1, features C per Gaussian), the UV arrays (triangles
//! u32, barycentrics 3, offsets 3, rotations 4, scales 3, opacities 1, features C) and, when the
//! header says `displaced`, one displacement per body vertex, then the skinned arrays (vertices
//! 4 u32, weights 4, offsets 3, rotations 4, scales 3, opacities 1, features C); each array
//! contiguous in that order. Version 2 added the source view and the displacements, version 3
//! the skinned Gaussians; earlier files still read.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use glam::{Mat4, Vec3};

use super::{Avatar, AvatarKind, LocalGaussians, SkinnedGaussians, UvGaussians};
use crate::body::BodyPose;
use crate::camera::Camera;
use crate::gaussians::{MAX_CHANNELS, MIN_CHANNELS};
use crate::photo::Crop;
use crate::tracking::{EhmIdentityRecord, SourceView};

pub const AVATAR_FORMAT: &str = "guava-rs avatar 3";
/// Files before the skinned Gaussians, and before the source view and displacements.
const AVATAR_FORMAT_2: &str = "guava-rs avatar 2";
const AVATAR_FORMAT_1: &str = "guava-rs avatar 1";

#[derive(Debug, thiserror::Error)]
#[error("{file}: {problem}")]
pub struct AvatarFileError {
    pub file: String,
    pub problem: String,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Header {
    kind: AvatarKind,
    body: String,
    body_vertices: usize,
    body_triangles: usize,
    channels: usize,
    identity: BTreeMap<String, f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    ehm_identity: Option<EhmIdentityRecord>,
    source: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    source_view: Option<ViewRecord>,
    #[serde(default)]
    displaced: bool,
    /// The last UV Gaussians on parts the photo did not show (version 2).
    #[serde(default)]
    outside: usize,
    template_gaussians: usize,
    uv_gaussians: usize,
    /// Version 3.
    #[serde(default)]
    skinned_gaussians: usize,
}

/// A [`SourceView`] as the header stores it: the pose in the bound body's joint and parameter
/// order, the camera in full, the photo's square.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewRecord {
    translation: [f32; 3],
    rotations: Vec<[f32; 3]>,
    coefficients: Vec<f32>,
    /// World → camera, column-major.
    view_from_world: [f32; 16],
    size: [u32; 2],
    focal: [f32; 2],
    principal: [f32; 2],
    near: f32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    crop: Option<[i64; 3]>,
}

impl ViewRecord {
    fn of(view: &SourceView) -> Self {
        let c = &view.camera;
        Self {
            translation: view.pose.translation.to_array(),
            rotations: view.pose.rotations.iter().map(|r| r.to_array()).collect(),
            coefficients: view.pose.coefficients.clone(),
            view_from_world: c.view_from_world.to_cols_array(),
            size: [c.width, c.height],
            focal: [c.fx, c.fy],
            principal: [c.cx, c.cy],
            near: c.near,
            crop: view.crop.map(Crop::to_array),
        }
    }

    fn view(self) -> Result<SourceView, String> {
        let finite = self.translation.iter().all(|v| v.is_finite())
            && self.rotations.iter().flatten().all(|v| v.is_finite())
            && self.coefficients.iter().all(|v| v.is_finite())
            && self.view_from_world.iter().all(|v| v.is_finite())
            && self
                .focal
                .iter()
                .chain(&self.principal)
                .all(|v| v.is_finite());
        if !finite {
            return Err("source_view: a value is not finite".into());
        }
        if self.size.contains(&0) || self.focal.iter().any(|f| *f <= 0.0) {
            return Err(format!(
                "source_view: the camera's size {:?} and focal lengths {:?} must be positive",
                self.size, self.focal
            ));
        }
        let crop = match self.crop {
            Some([left, top, side]) => {
                let fits = |v: i64| i32::try_from(v).is_ok();
                if !(fits(left) && fits(top) && (1..=i64::from(u32::MAX)).contains(&side)) {
                    return Err(format!(
                        "source_view.crop {:?} is out of range",
                        [left, top, side]
                    ));
                }
                Some(Crop {
                    left: left as i32,
                    top: top as i32,
                    side: side as u32,
                })
            }
            None => None,
        };
        Ok(SourceView {
            pose: BodyPose {
                translation: Vec3::from(self.translation),
                rotations: self.rotations.into_iter().map(Vec3::from).collect(),
                coefficients: self.coefficients,
            },
            camera: Camera {
                view_from_world: Mat4::from_cols_array(&self.view_from_world),
                width: self.size[0],
                height: self.size[1],
                fx: self.focal[0],
                fy: self.focal[1],
                cx: self.principal[0],
                cy: self.principal[1],
                near: self.near,
            },
            crop,
        })
    }
}

impl Avatar {
    pub fn save(&self, path: &Path) -> Result<(), AvatarFileError> {
        let header = Header {
            kind: self.kind,
            body: self.body.clone(),
            body_vertices: self.body_vertices,
            body_triangles: self.body_triangles,
            channels: self.channels,
            identity: self.identity.clone(),
            ehm_identity: self.ehm_identity.clone(),
            source: self.source.clone(),
            source_view: self.source_view.as_ref().map(ViewRecord::of),
            displaced: !self.displacements.is_empty(),
            outside: self.outside,
            template_gaussians: self.template.len(),
            uv_gaussians: self.uv.local.len(),
            skinned_gaussians: self.skinned.len(),
        };
        let json = serde_json::to_string(&header).map_err(|e| error(path, e.to_string()))?;
        crate::atomic_file::write_atomic(path, |out| {
            writeln!(out, "{AVATAR_FORMAT}")?;
            writeln!(out, "{json}")?;
            write_local(out, &self.template)?;
            let uv = &self.uv;
            write_words(out, uv.triangles.iter().copied())?;
            write_f32(out, uv.barycentrics.iter().flatten())?;
            write_f32(out, uv.offsets.iter().flatten())?;
            write_local(out, &uv.local)?;
            write_f32(out, self.displacements.iter())?;
            let k = &self.skinned;
            write_words(out, k.vertices.iter().flatten().copied())?;
            write_f32(out, k.weights.iter().flatten())?;
            write_f32(out, k.offsets.iter().flatten())?;
            write_local(out, &k.local)
        })
        .map_err(|e| error(path, format!("cannot write: {e}")))
    }

    pub fn load(path: &Path) -> Result<Self, AvatarFileError> {
        let bytes = std::fs::read(path).map_err(|e| error(path, format!("cannot read: {e}")))?;
        Self::from_bytes(&bytes, &path.display().to_string())
    }

    /// Parses and validates an avatar file's bytes; `file` names it in errors.
    pub fn from_bytes(bytes: &[u8], file: &str) -> Result<Self, AvatarFileError> {
        let fail = |problem: String| AvatarFileError {
            file: file.into(),
            problem,
        };
        let mut lines = bytes.splitn(3, |&b| b == b'\n');
        let version = lines.next().unwrap_or_default();
        if ![AVATAR_FORMAT, AVATAR_FORMAT_2, AVATAR_FORMAT_1]
            .iter()
            .any(|v| version == v.as_bytes())
        {
            return Err(fail(format!(
                "not an avatar file (the first line is not {AVATAR_FORMAT:?}, {AVATAR_FORMAT_2:?} \
                 or {AVATAR_FORMAT_1:?})"
            )));
        }
        let header: Header = serde_json::from_slice(lines.next().unwrap_or_default())
            .map_err(|e| fail(format!("header: {e}")))?;
        if version == AVATAR_FORMAT_1.as_bytes()
            && (header.displaced || header.source_view.is_some())
        {
            return Err(fail(
                "header: a version 1 file has no source_view or displaced".into(),
            ));
        }
        if version != AVATAR_FORMAT.as_bytes() && header.skinned_gaussians > 0 {
            return Err(fail(
                "header: only a version 3 file has skinned_gaussians".into(),
            ));
        }
        let body = lines.next().unwrap_or_default();
        let c = header.channels;
        if !(MIN_CHANNELS..=MAX_CHANNELS).contains(&c) {
            return Err(fail(format!(
                "header: channels is {c}, outside {MIN_CHANNELS}..={MAX_CHANNELS}"
            )));
        }
        if header.template_gaussians != header.body_vertices {
            return Err(fail(format!(
                "header: {} template Gaussians for a body of {} vertices (one per vertex)",
                header.template_gaussians, header.body_vertices
            )));
        }
        let (nt, nu, ns) = (
            header.template_gaussians,
            header.uv_gaussians,
            header.skinned_gaussians,
        );
        let nd = if header.displaced {
            header.body_vertices
        } else {
            0
        };
        // Counted in u128: a hostile header's counts must not overflow into a small size.
        let words = nt as u128 * (8 + c as u128)
            + nu as u128 * (1 + 3 + 3 + 8 + c as u128)
            + nd as u128
            + ns as u128 * (4 + 4 + 3 + 8 + c as u128);
        if body.len() as u128 != 4 * words {
            return Err(fail(format!(
                "the arrays take {} bytes, expected {} for {nt} template, {nu} UV and {ns} skinned \
                 Gaussians with {c} channels{}",
                body.len(),
                4 * words,
                if nd > 0 {
                    format!(" and {nd} displacements")
                } else {
                    String::new()
                }
            )));
        }
        let mut reader = Words(body);
        let template = read_local(&mut reader, nt, c);
        let triangles = reader.u32s(nu);
        let barycentrics = reader.arrays(nu);
        let offsets = reader.arrays(nu);
        let local = read_local(&mut reader, nu, c);
        let displacements = reader.f32s(nd);
        let skinned = SkinnedGaussians {
            vertices: reader
                .u32s(4 * ns)
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect(),
            weights: reader.arrays(ns),
            offsets: reader.arrays(ns),
            local: read_local(&mut reader, ns, c),
        };
        let source_view = header
            .source_view
            .map(ViewRecord::view)
            .transpose()
            .map_err(fail)?;
        let avatar = Avatar {
            kind: header.kind,
            body: header.body,
            body_vertices: header.body_vertices,
            body_triangles: header.body_triangles,
            channels: c,
            identity: header.identity,
            ehm_identity: header.ehm_identity,
            source: header.source,
            source_view,
            displacements,
            template,
            uv: UvGaussians {
                triangles,
                barycentrics,
                offsets,
                local,
            },
            skinned,
            outside: header.outside,
        };
        avatar.validate().map_err(fail)?;
        Ok(avatar)
    }

    /// Checks what animation and splatting rely on; the problem names the array and index.
    pub fn validate(&self) -> Result<(), String> {
        if self.outside > self.uv.local.len() {
            return Err(format!(
                "outside is {}, but there are {} UV Gaussians",
                self.outside,
                self.uv.local.len()
            ));
        }
        if let Some((name, value)) = self.identity.iter().find(|(_, v)| !v.is_finite()) {
            return Err(format!("identity {name:?} is {value}"));
        }
        if let Some(ehm) = &self.ehm_identity {
            ehm.check()
                .map_err(|(field, p)| format!("ehm_identity.{field}: {p}"))?;
        }
        if let Some(i) = self
            .uv
            .triangles
            .iter()
            .position(|&t| t as usize >= self.body_triangles)
        {
            return Err(format!(
                "uv triangles[{i}] is {}, but the body has {} triangles",
                self.uv.triangles[i], self.body_triangles
            ));
        }
        let k = &self.skinned;
        if let Some(i) = k
            .vertices
            .iter()
            .position(|v| v.iter().any(|&v| v as usize >= self.body_vertices))
        {
            return Err(format!(
                "skinned vertices[{i}] is {:?}, but the body has {} vertices",
                k.vertices[i], self.body_vertices
            ));
        }
        if let Some(i) = k.weights.iter().position(|w| {
            let sum: f32 = w.iter().sum();
            w.iter().any(|x| !(x.is_finite() && *x >= 0.0)) || (sum - 1.0).abs() > 1e-3
        }) {
            return Err(format!(
                "skinned weights[{i}] is {:?}: weights are ≥ 0 and sum to 1",
                k.weights[i]
            ));
        }
        let finite = |name: &str, values: &mut dyn Iterator<Item = f32>| match values
            .enumerate()
            .find(|(_, v)| !v.is_finite())
        {
            Some((i, v)) => Err(format!("{name} value {i} is {v}")),
            None => Ok(()),
        };
        for (set, g) in [
            ("template", &self.template),
            ("uv", &self.uv.local),
            ("skinned", &self.skinned.local),
        ] {
            finite(
                &format!("{set} rotations"),
                &mut g.rotations.iter().flatten().copied(),
            )?;
            finite(&format!("{set} features"), &mut g.features.iter().copied())?;
            if let Some(i) = g
                .scales
                .iter()
                .position(|s| s.iter().any(|x| !(x.is_finite() && *x >= 0.0)))
            {
                return Err(format!(
                    "{set} scales[{i}] is {:?}: scales must be finite and ≥ 0",
                    g.scales[i]
                ));
            }
            if let Some(i) = g.opacities.iter().position(|o| !(0.0..=1.0).contains(o)) {
                return Err(format!(
                    "{set} opacities[{i}] is {}: opacities must be in [0, 1]",
                    g.opacities[i]
                ));
            }
        }
        finite(
            "uv barycentrics",
            &mut self.uv.barycentrics.iter().flatten().copied(),
        )?;
        finite("uv offsets", &mut self.uv.offsets.iter().flatten().copied())?;
        finite("skinned offsets", &mut k.offsets.iter().flatten().copied())?;
        if !self.displacements.is_empty() && self.displacements.len() != self.body_vertices {
            return Err(format!(
                "{} displacements for a body of {} vertices (one per vertex)",
                self.displacements.len(),
                self.body_vertices
            ));
        }
        finite("displacements", &mut self.displacements.iter().copied())
    }
}

fn error(path: &Path, problem: String) -> AvatarFileError {
    AvatarFileError {
        file: path.display().to_string(),
        problem,
    }
}

fn write_f32<'a>(
    out: &mut impl Write,
    values: impl Iterator<Item = &'a f32>,
) -> std::io::Result<()> {
    write_words(out, values.map(|v| v.to_bits()))
}

fn write_words(out: &mut impl Write, values: impl Iterator<Item = u32>) -> std::io::Result<()> {
    for v in values {
        out.write_all(&v.to_le_bytes())?;
    }
    Ok(())
}

fn write_local(out: &mut impl Write, g: &LocalGaussians) -> std::io::Result<()> {
    write_f32(out, g.rotations.iter().flatten())?;
    write_f32(out, g.scales.iter().flatten())?;
    write_f32(out, g.opacities.iter())?;
    write_f32(out, g.features.iter())
}

/// Little-endian words taken from the front of a byte slice whose length was checked.
struct Words<'a>(&'a [u8]);

impl Words<'_> {
    fn u32s(&mut self, n: usize) -> Vec<u32> {
        let (head, rest) = self.0.split_at(4 * n);
        self.0 = rest;
        head.chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    }

    fn f32s(&mut self, n: usize) -> Vec<f32> {
        self.u32s(n).into_iter().map(f32::from_bits).collect()
    }

    fn arrays<const N: usize>(&mut self, n: usize) -> Vec<[f32; N]> {
        self.f32s(N * n)
            .chunks_exact(N)
            .map(|c| std::array::from_fn(|k| c[k]))
            .collect()
    }
}

fn read_local(r: &mut Words, n: usize, channels: usize) -> LocalGaussians {
    LocalGaussians {
        rotations: r.arrays(n),
        scales: r.arrays(n),
        opacities: r.f32s(n),
        features: r.f32s(n * channels),
    }
}
