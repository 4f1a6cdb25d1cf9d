//! 3D Gaussian Splatting PLY files (the format of the original 3DGS code and most published
//! splats): `x y z`, `f_dc_0..2` (degree-0 SH), `f_rest_*` (higher SH, ignored: the viewer draws
//! view-independent colour), `opacity` as a logit, `scale_0..2` as logs, `rot_0..3` as (w, x, y, z).
//! Channels beyond RGB are stored as `feat_3 … feat_{C−1}`, so 32-channel GUAVA clouds round-trip.
//! Reading applies the activations (sigmoid, exp, SH DC → colour, quaternion normalisation, as
//! 3DGS's `GaussianModel` getters do); writing inverts them.

use super::{GaussianCloud, MAX_CHANNELS};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Degree-0 spherical-harmonic constant: colour = 0.5 + SH_C0 · f_dc.
pub const SH_C0: f32 = 0.282_094_8;

#[derive(Debug, Error)]
pub enum PlyError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {problem}")]
    Format { path: PathBuf, problem: String },
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Encoding {
    Ascii,
    BinaryLittle,
    BinaryBig,
}

#[derive(Clone, Copy, Debug)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn read(self, b: &[u8], big: bool) -> f64 {
        macro_rules! get {
            ($t:ty, $n:literal) => {{
                let a: [u8; $n] = b[..$n].try_into().expect("slice has the scalar's size");
                (if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }) as f64
            }};
        }
        match self {
            Self::I8 => b[0] as i8 as f64,
            Self::U8 => b[0] as f64,
            Self::I16 => get!(i16, 2),
            Self::U16 => get!(u16, 2),
            Self::I32 => get!(i32, 4),
            Self::U32 => get!(u32, 4),
            Self::F32 => get!(f32, 4),
            Self::F64 => get!(f64, 8),
        }
    }
}

struct Header {
    encoding: Encoding,
    count: usize,
    properties: Vec<(String, Scalar)>,
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

pub fn read(path: &Path) -> Result<GaussianCloud, PlyError> {
    let file = std::fs::File::open(path).map_err(|source| PlyError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_from(BufReader::new(file), path)
}

/// Reads from any stream; `path` only names the source in errors.
pub fn read_from(mut input: impl BufRead, path: &Path) -> Result<GaussianCloud, PlyError> {
    let fail = |problem: String| PlyError::Format {
        path: path.to_path_buf(),
        problem,
    };
    let header = read_header(&mut input).map_err(fail)?;
    let find = |name: &str| header.properties.iter().position(|(n, _)| n == name);
    let require =
        |name: &str| find(name).ok_or_else(|| fail(format!("vertex property `{name}` is missing")));
    let pos = [require("x")?, require("y")?, require("z")?];
    let opacity = require("opacity")?;
    let scale = [
        require("scale_0")?,
        require("scale_1")?,
        require("scale_2")?,
    ];
    let rot = [
        require("rot_0")?,
        require("rot_1")?,
        require("rot_2")?,
        require("rot_3")?,
    ];
    let dc = [require("f_dc_0")?, require("f_dc_1")?, require("f_dc_2")?];
    let mut extra = Vec::new();
    while let Some(i) = find(&format!("feat_{}", 3 + extra.len())) {
        extra.push(i);
    }
    let channels = 3 + extra.len();
    if channels > MAX_CHANNELS {
        return Err(fail(format!(
            "{channels} feature channels; at most {MAX_CHANNELS} are supported"
        )));
    }

    let mut cloud = GaussianCloud::new(channels);
    let mut row = vec![0.0f64; header.properties.len()];
    let mut feats = vec![0.0f32; channels];
    let row_bytes: usize = header.properties.iter().map(|(_, s)| s.size()).sum();
    let mut buf = vec![0u8; row_bytes];
    let mut lines = String::new();
    for v in 0..header.count {
        match header.encoding {
            Encoding::Ascii => {
                lines.clear();
                input
                    .read_line(&mut lines)
                    .map_err(|e| fail(format!("vertex {v}: {e}")))?;
                let mut values = lines.split_ascii_whitespace();
                for (k, slot) in row.iter_mut().enumerate() {
                    let text = values.next().ok_or_else(|| {
                        fail(format!(
                            "vertex {v}: only {k} of {} values",
                            header.properties.len()
                        ))
                    })?;
                    *slot = text.parse().map_err(|_| {
                        fail(format!(
                            "vertex {v}, property `{}`: `{text}` is not a number",
                            header.properties[k].0
                        ))
                    })?;
                }
            }
            Encoding::BinaryLittle | Encoding::BinaryBig => {
                input.read_exact(&mut buf).map_err(|_| {
                    fail(format!(
                        "file ends at vertex {v} of {}: truncated",
                        header.count
                    ))
                })?;
                let big = header.encoding == Encoding::BinaryBig;
                let mut at = 0;
                for (k, (_, s)) in header.properties.iter().enumerate() {
                    row[k] = s.read(&buf[at..], big);
                    at += s.size();
                }
            }
        }
        let get = |i: usize| row[i] as f32;
        let q = rot.map(get);
        let norm = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        let q = if norm > 0.0 { q.map(|c| c / norm) } else { q };
        for c in 0..3 {
            feats[c] = 0.5 + SH_C0 * get(dc[c]);
        }
        for (k, &i) in extra.iter().enumerate() {
            feats[3 + k] = get(i);
        }
        cloud.push(
            pos.map(get),
            q,
            scale.map(|i| get(i).exp()),
            sigmoid(get(opacity)),
            &feats,
        );
    }
    Ok(cloud)
}

fn read_header(input: &mut impl BufRead) -> Result<Header, String> {
    let mut line = String::new();
    let mut next = |line: &mut String| -> Result<(), String> {
        line.clear();
        match input.read_line(line) {
            Ok(0) => Err("header ends before `end_header`".into()),
            Ok(_) => Ok(()),
            Err(e) => Err(format!("reading the header: {e}")),
        }
    };
    next(&mut line)?;
    if line.trim_end() != "ply" {
        return Err("not a PLY file (first line is not `ply`)".into());
    }
    let mut encoding = None;
    let mut count = None;
    let mut properties = Vec::new();
    let mut in_vertex = false;
    loop {
        next(&mut line)?;
        let words: Vec<&str> = line.split_ascii_whitespace().collect();
        match words.as_slice() {
            ["end_header"] => break,
            ["format", f, _] => {
                encoding = Some(match *f {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::BinaryLittle,
                    "binary_big_endian" => Encoding::BinaryBig,
                    other => return Err(format!("unknown format `{other}`")),
                })
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["element", name, n] => {
                if count.is_some() && !in_vertex {
                    continue;
                }
                if *name == "vertex" {
                    count = Some(
                        n.parse::<usize>()
                            .map_err(|_| format!("vertex count `{n}` is not a number"))?,
                    );
                    in_vertex = true;
                } else if count.is_none() {
                    return Err(format!("element `{name}` before `vertex` is not supported"));
                } else {
                    in_vertex = false;
                }
            }
            ["property", "list", ..] if in_vertex => {
                return Err("list properties on vertices are not supported".into());
            }
            ["property", ty, name] if in_vertex => {
                let scalar = Scalar::parse(ty)
                    .ok_or_else(|| format!("property `{name}` has unknown type `{ty}`"))?;
                properties.push((name.to_string(), scalar));
            }
            ["property", ..] => {}
            _ => return Err(format!("unexpected header line `{}`", line.trim_end())),
        }
    }
    Ok(Header {
        encoding: encoding.ok_or("header has no `format` line")?,
        count: count.ok_or("header has no `element vertex`")?,
        properties,
    })
}

/// Writes binary little-endian 3DGS PLY via a temporary file renamed into place, so an
/// interrupted write never leaves a half-written file under `path`.
pub fn write(path: &Path, cloud: &GaussianCloud) -> Result<(), PlyError> {
    let io = |source| PlyError::Io {
        path: path.to_path_buf(),
        source,
    };
    if cloud.channels < 3 {
        return Err(PlyError::Format {
            path: path.to_path_buf(),
            problem: format!(
                "3DGS PLY needs at least 3 channels (RGB), the cloud has {}",
                cloud.channels
            ),
        });
    }
    crate::atomic_file::write_atomic(path, |out| write_rows(out, cloud)).map_err(io)
}

fn write_rows(out: &mut impl Write, cloud: &GaussianCloud) -> std::io::Result<()> {
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by guava-rs\nelement vertex {}\n",
        cloud.len()
    );
    let mut names: Vec<String> = [
        "x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2",
    ]
    .map(String::from)
    .to_vec();
    names.extend((3..cloud.channels).map(|c| format!("feat_{c}")));
    names.extend(
        [
            "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
        ]
        .map(String::from),
    );
    for n in &names {
        header.push_str(&format!("property float {n}\n"));
    }
    header.push_str("end_header\n");
    out.write_all(header.as_bytes())?;
    let mut row = Vec::with_capacity(names.len());
    for i in 0..cloud.len() {
        row.clear();
        row.extend_from_slice(&cloud.positions[i]);
        row.extend_from_slice(&[0.0; 3]);
        let f = cloud.features_of(i);
        row.extend(f[..3].iter().map(|c| (c - 0.5) / SH_C0));
        row.extend_from_slice(&f[3..]);
        let o = cloud.opacities[i].clamp(1e-7, 1.0 - 1e-7);
        row.push((o / (1.0 - o)).ln());
        row.extend(cloud.scales[i].iter().map(|s| s.ln()));
        row.extend_from_slice(&cloud.rotations[i]);
        for v in &row {
            out.write_all(&v.to_le_bytes())?;
        }
    }
    Ok(())
}
