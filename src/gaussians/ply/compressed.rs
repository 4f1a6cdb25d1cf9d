//! PlayCanvas's compressed 3DGS PLY, which SuperSplat and splat-transform write as
//! `.compressed.ply`. Splats come in chunks of 256. Each chunk has min/max bounds of position,
//! log-scale and (optionally) colour. Each splat has four uint32s: position and log-scale as 11/10/11
//! bits within its chunk's bounds, the rotation as the index of its largest component (2 bits)
//! and the other three in 10 bits each, and colour as RGBA in 8 bits each (alpha is the opacity
//! itself, not a logit). Higher SH (an `sh` element after the vertices) is ignored, like `f_rest_*`.
//! The decoding follows PlayCanvas's engine (`gsplat-compressed-data.js`) and splat-transform, in
//! f64 as they compute; tests/ply.rs compares it with splat-transform's own decoding.

use super::Element;

/// Splats per chunk: splat `i` takes the bounds of chunk `i / CHUNK_SPLATS`.
pub const CHUNK_SPLATS: usize = 256;

/// The vertex properties that mark a compressed file, in the order [`Packed`] holds them.
pub const PACKED: [&str; 4] = [
    "packed_position",
    "packed_rotation",
    "packed_scale",
    "packed_color",
];

const BOUNDS: [&str; 12] = [
    "min_x",
    "min_y",
    "min_z",
    "max_x",
    "max_y",
    "max_z",
    "min_scale_x",
    "min_scale_y",
    "min_scale_z",
    "max_scale_x",
    "max_scale_y",
    "max_scale_z",
];
const COLOUR_BOUNDS: [&str; 6] = ["min_r", "min_g", "min_b", "max_r", "max_g", "max_b"];

/// One chunk's bounds: position and log-scale, then colour where the file has it.
#[derive(Clone, Copy, Debug)]
pub struct Chunk {
    bounds: [f64; 12],
    colour: Option<[f64; 6]>,
}

/// Where a `chunk` element keeps each bound.
pub struct ChunkColumns {
    bounds: [usize; 12],
    colour: Option<[usize; 6]>,
}

impl ChunkColumns {
    pub fn new(chunk: &Element) -> Result<Self, String> {
        let bounds = chunk.require_all(BOUNDS)?;
        // Colour bounds come all together or not at all (then colours span 0…1).
        let colour = match chunk.find(COLOUR_BOUNDS[0]) {
            Some(_) => Some(chunk.require_all(COLOUR_BOUNDS)?),
            None => None,
        };
        Ok(Self { bounds, colour })
    }

    pub fn chunk(&self, row: &[f64]) -> Chunk {
        Chunk {
            bounds: self.bounds.map(|i| row[i]),
            colour: self.colour.map(|c| c.map(|i| row[i])),
        }
    }
}

/// One splat's four packed words, in [`PACKED`] order.
pub type Packed = [u32; 4];

/// A decoded splat, activated as the cloud stores it.
pub struct Splat {
    pub position: [f32; 3],
    /// (w, x, y, z), unit length.
    pub rotation: [f32; 4],
    pub scale: [f32; 3],
    pub opacity: f32,
    pub colour: [f32; 3],
}

fn unorm(value: u32, bits: u32) -> f64 {
    let top = (1u32 << bits) - 1;
    f64::from(value & top) / f64::from(top)
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a * (1.0 - t) + b * t
}

/// 11/10/11 bits, x in the high bits, each placed between a min and a max.
fn unpack_111011(word: u32, min: &[f64], max: &[f64]) -> [f64; 3] {
    let t = [
        unorm(word >> 21, 11),
        unorm(word >> 11, 10),
        unorm(word, 11),
    ];
    std::array::from_fn(|k| lerp(min[k], max[k], t[k]))
}

pub fn decode(chunk: &Chunk, [position, rotation, scale, colour]: Packed) -> Splat {
    let bounds = &chunk.bounds;
    let p = unpack_111011(position, &bounds[0..3], &bounds[3..6]);
    let log_scale = unpack_111011(scale, &bounds[6..9], &bounds[9..12]);

    // The three smaller components lie in ±1/√2; the largest follows from unit length.
    let [a, b, c] =
        [20, 10, 0].map(|shift| (unorm(rotation >> shift, 10) - 0.5) * std::f64::consts::SQRT_2);
    let m = (1.0 - (a * a + b * b + c * c)).max(0.0).sqrt();
    let q = match rotation >> 30 {
        0 => [m, a, b, c],
        1 => [a, m, b, c],
        2 => [a, b, m, c],
        _ => [a, b, c, m],
    };
    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();

    let rgb = [24, 16, 8].map(|shift| unorm(colour >> shift, 8));
    let rgb: [f64; 3] = match &chunk.colour {
        Some(cb) => std::array::from_fn(|k| lerp(cb[k], cb[3 + k], rgb[k])),
        None => rgb,
    };
    Splat {
        position: p.map(|v| v as f32),
        rotation: q.map(|v| (v / norm) as f32),
        scale: log_scale.map(|v| v.exp() as f32),
        opacity: unorm(colour, 8) as f32,
        colour: rgb.map(|v| v as f32),
    }
}
