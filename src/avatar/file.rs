//! The avatar file (`.guava`): a JSON header line and the arrays as little-endian f32/u32, so a
//! saved avatar loads back bit for bit. Written through a temporary file and renamed into place.
//!
//! Layout: `guava-rs avatar 1\n`, the header (one line of JSON), `\n`, then the template arrays
//! (rotations 4, scales 3, opacities 1, features C per Gaussian) and the UV arrays (triangles
//! u32, barycentrics 3, offsets 3, rotations 4, scales 3, opacities 1, features C), each array
//! contiguous in that order.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{Avatar, AvatarKind, LocalGaussians, UvGaussians};
use crate::gaussians::{MAX_CHANNELS, MIN_CHANNELS};
use crate::tracking::EhmIdentityRecord;

pub const AVATAR_FORMAT: &str = "guava-rs avatar 1";

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
    template_gaussians: usize,
    uv_gaussians: usize,
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
            template_gaussians: self.template.len(),
            uv_gaussians: self.uv.local.len(),
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
            write_local(out, &uv.local)
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
        if lines.next() != Some(AVATAR_FORMAT.as_bytes()) {
            return Err(fail(format!(
                "not an avatar file (the first line is not {AVATAR_FORMAT:?})"
            )));
        }
        let header: Header = serde_json::from_slice(lines.next().unwrap_or_default())
            .map_err(|e| fail(format!("header: {e}")))?;
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
        let (nt, nu) = (header.template_gaussians, header.uv_gaussians);
        let words = nt * (8 + c) + nu * (1 + 3 + 3 + 8 + c);
        if body.len() != 4 * words {
            return Err(fail(format!(
                "the arrays take {} bytes, expected {} for {nt} template and {nu} UV Gaussians with {c} channels",
                body.len(),
                4 * words
            )));
        }
        let mut reader = Words(body);
        let template = read_local(&mut reader, nt, c);
        let triangles = reader.u32s(nu);
        let barycentrics = reader.arrays(nu);
        let offsets = reader.arrays(nu);
        let local = read_local(&mut reader, nu, c);
        let avatar = Avatar {
            kind: header.kind,
            body: header.body,
            body_vertices: header.body_vertices,
            body_triangles: header.body_triangles,
            channels: c,
            identity: header.identity,
            ehm_identity: header.ehm_identity,
            source: header.source,
            template,
            uv: UvGaussians {
                triangles,
                barycentrics,
                offsets,
                local,
            },
        };
        avatar.validate().map_err(fail)?;
        Ok(avatar)
    }

    /// Checks what animation and splatting rely on; the problem names the array and index.
    pub fn validate(&self) -> Result<(), String> {
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
        let finite = |name: &str, values: &mut dyn Iterator<Item = f32>| match values
            .enumerate()
            .find(|(_, v)| !v.is_finite())
        {
            Some((i, v)) => Err(format!("{name} value {i} is {v}")),
            None => Ok(()),
        };
        for (set, g) in [("template", &self.template), ("uv", &self.uv.local)] {
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
        finite("uv offsets", &mut self.uv.offsets.iter().flatten().copied())
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
