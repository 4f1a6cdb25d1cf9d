//! 3D Gaussian Splatting PLY files (the format of the original 3DGS code and most published
//! splats): `x y z`, `f_dc_0..2` (degree-0 SH), `f_rest_*` (higher SH, ignored: the viewer draws
//! view-independent colour), `opacity` as a logit, `scale_0..2` as logs, `rot_0..3` as (w, x, y, z).
//! Channels beyond RGB are stored as `feat_3 … feat_{C−1}`, so 32-channel GUAVA clouds round-trip.
//! Reading applies the activations (sigmoid, exp, SH DC → colour, quaternion normalisation, as
//! 3DGS's `GaussianModel` getters do); writing inverts them. A standard file's colours (no
//! `feat_*` channels) are clamped at 0, as 3DGS's rasterizer clamps each Gaussian's SH colour
//! before blending (`computeColorFromSH`), so published scenes shade as in the viewers users
//! compare with; feature channels (GUAVA's) stay as stored. Reading also takes PlayCanvas's
//! compressed layout (SuperSplat's `.compressed.ply`, [`compressed`]); writing is always the
//! standard one.

mod compressed;

use super::{CloudFileError, GaussianCloud, MAX_CHANNELS, unit_quaternion};
use std::io::{BufRead, BufReader, Write};
use std::path::Path;

/// Degree-0 spherical-harmonic constant: colour = 0.5 + SH_C0 · f_dc.
pub const SH_C0: f32 = 0.282_094_8;

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

/// One `element` of the header: its rows and their scalar properties in file order.
struct Element {
    name: String,
    count: usize,
    properties: Vec<(String, Scalar)>,
    /// A list property (meshes' faces): such rows cannot be read, only ignored after the vertices.
    has_list: bool,
}

impl Element {
    fn find(&self, name: &str) -> Option<usize> {
        self.properties.iter().position(|(n, _)| n == name)
    }

    /// The column of a property the layout needs, or the problem naming it.
    fn require(&self, name: &str) -> Result<usize, String> {
        self.find(name)
            .ok_or_else(|| format!("{} property `{name}` is missing", self.name))
    }

    /// [`Self::require`] for each of `names`, in order.
    fn require_all<const N: usize>(&self, names: [&str; N]) -> Result<[usize; N], String> {
        let mut columns = [0; N];
        for (slot, name) in columns.iter_mut().zip(names) {
            *slot = self.require(name)?;
        }
        Ok(columns)
    }
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

pub fn read(path: &Path) -> Result<GaussianCloud, CloudFileError> {
    let file = std::fs::File::open(path).map_err(|error| CloudFileError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    read_from(BufReader::new(file), path)
}

/// Reads from any stream; `path` only names the source in errors. Reads the standard 3DGS layout
/// and PlayCanvas's compressed one (vertices with `packed_position`, see [`compressed`]).
pub fn read_from(mut input: impl BufRead, path: &Path) -> Result<GaussianCloud, CloudFileError> {
    let fail = |problem: String| CloudFileError::Format {
        path: path.to_path_buf(),
        problem,
    };
    let header = read_header(&mut input).map_err(fail)?;
    let vertex_at = header
        .elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| fail("header has no `element vertex`".into()))?;
    let vertex = &header.elements[vertex_at];
    let is_compressed = vertex.find(compressed::PACKED[0]).is_some();
    // Elements before the vertices are read past, except a compressed file's chunk bounds; those
    // after them are never read.
    let mut chunks = Vec::new();
    for element in &header.elements[..vertex_at] {
        if is_compressed && element.name == "chunk" {
            let columns = compressed::ChunkColumns::new(element).map_err(fail)?;
            for_each_row(&mut input, header.encoding, element, &fail, |_, row| {
                chunks.push(columns.chunk(row));
                Ok(())
            })?;
        } else {
            for_each_row(&mut input, header.encoding, element, &fail, |_, _| Ok(()))?;
        }
    }
    if is_compressed {
        read_compressed(&mut input, header.encoding, vertex, &chunks, &fail)
    } else {
        read_standard(&mut input, header.encoding, vertex, &fail)
    }
}

/// Hands each of `element`'s rows to `each` with its index, as f64 values in property order.
fn for_each_row(
    input: &mut impl BufRead,
    encoding: Encoding,
    element: &Element,
    fail: &impl Fn(String) -> CloudFileError,
    mut each: impl FnMut(usize, &[f64]) -> Result<(), CloudFileError>,
) -> Result<(), CloudFileError> {
    let name = &element.name;
    if element.has_list {
        return Err(fail(format!(
            "element `{name}` has list properties, which are not supported before or on the vertices"
        )));
    }
    let mut row = vec![0.0f64; element.properties.len()];
    let row_bytes: usize = element.properties.iter().map(|(_, s)| s.size()).sum();
    let mut buf = vec![0u8; row_bytes];
    let mut line = String::new();
    for r in 0..element.count {
        match encoding {
            Encoding::Ascii => {
                line.clear();
                input
                    .read_line(&mut line)
                    .map_err(|e| fail(format!("{name} {r}: {e}")))?;
                let mut values = line.split_ascii_whitespace();
                for (k, slot) in row.iter_mut().enumerate() {
                    let text = values.next().ok_or_else(|| {
                        fail(format!(
                            "{name} {r}: only {k} of {} values",
                            element.properties.len()
                        ))
                    })?;
                    *slot = text.parse().map_err(|_| {
                        fail(format!(
                            "{name} {r}, property `{}`: `{text}` is not a number",
                            element.properties[k].0
                        ))
                    })?;
                }
            }
            Encoding::BinaryLittle | Encoding::BinaryBig => {
                input.read_exact(&mut buf).map_err(|_| {
                    fail(format!(
                        "file ends at {name} {r} of {}: truncated",
                        element.count
                    ))
                })?;
                let big = encoding == Encoding::BinaryBig;
                let mut at = 0;
                for (k, (_, s)) in element.properties.iter().enumerate() {
                    row[k] = s.read(&buf[at..], big);
                    at += s.size();
                }
            }
        }
        each(r, &row)?;
    }
    Ok(())
}

/// The standard 3DGS layout, with `feat_*` channels beyond RGB.
fn read_standard(
    input: &mut impl BufRead,
    encoding: Encoding,
    vertex: &Element,
    fail: &impl Fn(String) -> CloudFileError,
) -> Result<GaussianCloud, CloudFileError> {
    let columns = |names| vertex.require_all(names).map_err(fail);
    let pos = columns(["x", "y", "z"])?;
    let opacity = vertex.require("opacity").map_err(fail)?;
    let scale = columns(["scale_0", "scale_1", "scale_2"])?;
    let dc = columns(["f_dc_0", "f_dc_1", "f_dc_2"])?;
    let rot = vertex
        .require_all(["rot_0", "rot_1", "rot_2", "rot_3"])
        .map_err(fail)?;
    let mut extra = Vec::new();
    while let Some(i) = vertex.find(&format!("feat_{}", 3 + extra.len())) {
        extra.push(i);
    }
    let channels = 3 + extra.len();
    if channels > MAX_CHANNELS {
        return Err(fail(format!(
            "{channels} feature channels; at most {MAX_CHANNELS} are supported"
        )));
    }

    let mut cloud = GaussianCloud::new(channels);
    let mut feats = vec![0.0f32; channels];
    for_each_row(input, encoding, vertex, fail, |_, row| {
        let get = |i: usize| row[i] as f32;
        for c in 0..3 {
            feats[c] = 0.5 + SH_C0 * get(dc[c]);
        }
        if extra.is_empty() {
            clamp_colour(&mut feats);
        }
        for (k, &i) in extra.iter().enumerate() {
            feats[3 + k] = get(i);
        }
        cloud.push(
            pos.map(get),
            unit_quaternion(rot.map(get)),
            scale.map(|i| get(i).exp()),
            sigmoid(get(opacity)),
            &feats,
        );
        Ok(())
    })?;
    Ok(cloud)
}

/// PlayCanvas's compressed layout: packed vertices decoded within their chunk's bounds.
fn read_compressed(
    input: &mut impl BufRead,
    encoding: Encoding,
    vertex: &Element,
    chunks: &[compressed::Chunk],
    fail: &impl Fn(String) -> CloudFileError,
) -> Result<GaussianCloud, CloudFileError> {
    let packed = vertex.require_all(compressed::PACKED).map_err(fail)?;
    let needed = vertex.count.div_ceil(compressed::CHUNK_SPLATS);
    if chunks.len() < needed {
        return Err(fail(format!(
            "element `chunk` has {} rows before the vertices; {} compressed vertices need {needed}",
            chunks.len(),
            vertex.count
        )));
    }
    let mut cloud = GaussianCloud::new(3);
    for_each_row(input, encoding, vertex, fail, |v, row| {
        let words = packed.map(|i| row[i]);
        if let Some(bad) = words
            .iter()
            .position(|&w| w < 0.0 || w > f64::from(u32::MAX) || w.fract() != 0.0)
        {
            return Err(fail(format!(
                "vertex {v}, property `{}`: {} is not a packed 32-bit word",
                compressed::PACKED[bad],
                words[bad]
            )));
        }
        let mut splat = compressed::decode(
            &chunks[v / compressed::CHUNK_SPLATS],
            words.map(|w| w as u32),
        );
        clamp_colour(&mut splat.colour);
        cloud.push(
            splat.position,
            splat.rotation,
            splat.scale,
            splat.opacity,
            &splat.colour,
        );
        Ok(())
    })?;
    Ok(cloud)
}

/// 3DGS's rule for a Gaussian's colour: no channel below 0 (`computeColorFromSH` returns
/// `max(result, 0)`); above 1 is left to the final image.
fn clamp_colour(rgb: &mut [f32]) {
    for c in rgb {
        *c = c.max(0.0);
    }
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
    let mut elements: Vec<Element> = Vec::new();
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
            ["element", name, n] => elements.push(Element {
                name: name.to_string(),
                count: n
                    .parse()
                    .map_err(|_| format!("{name} count `{n}` is not a number"))?,
                properties: Vec::new(),
                has_list: false,
            }),
            ["property", rest @ ..] => {
                let element = elements
                    .last_mut()
                    .ok_or("a `property` line before any `element`")?;
                match rest {
                    ["list", ..] => element.has_list = true,
                    [ty, name] => {
                        let scalar = Scalar::parse(ty)
                            .ok_or_else(|| format!("property `{name}` has unknown type `{ty}`"))?;
                        element.properties.push((name.to_string(), scalar));
                    }
                    _ => return Err(format!("unexpected header line `{}`", line.trim_end())),
                }
            }
            _ => return Err(format!("unexpected header line `{}`", line.trim_end())),
        }
    }
    Ok(Header {
        encoding: encoding.ok_or("header has no `format` line")?,
        elements,
    })
}

/// Writes binary little-endian 3DGS PLY via a temporary file renamed into place, so an
/// interrupted write never leaves a half-written file under `path`.
pub fn write(path: &Path, cloud: &GaussianCloud) -> Result<(), CloudFileError> {
    let io = |error| CloudFileError::Io {
        path: path.to_path_buf(),
        error,
    };
    if cloud.channels < 3 {
        return Err(CloudFileError::Format {
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
