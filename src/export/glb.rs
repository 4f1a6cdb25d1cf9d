//! A binary glTF 2.0 (`.glb`) being built: typed arrays go into one binary chunk as accessors
//! (dense, or sparse for morph targets that move few vertices), the JSON is assembled by the
//! caller around the indices handed back, and the file is written atomically.

use std::io::Write;
use std::path::Path;

use serde_json::{Value, json};

/// glTF's component types and buffer-view targets.
const FLOAT: u32 = 5126;
const UNSIGNED_BYTE: u32 = 5121;
const UNSIGNED_INT: u32 = 5125;
pub const ARRAY_BUFFER: u32 = 34962;
pub const ELEMENT_ARRAY_BUFFER: u32 = 34963;

#[derive(Default)]
pub struct Glb {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

/// An accessor's element type: how many components and glTF's name for it.
#[derive(Clone, Copy)]
pub enum Kind {
    Scalar,
    Vec2,
    Vec3,
    Vec4,
    Mat4,
}

impl Kind {
    fn components(self) -> usize {
        match self {
            Kind::Scalar => 1,
            Kind::Vec2 => 2,
            Kind::Vec3 => 3,
            Kind::Vec4 => 4,
            Kind::Mat4 => 16,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Kind::Scalar => "SCALAR",
            Kind::Vec2 => "VEC2",
            Kind::Vec3 => "VEC3",
            Kind::Vec4 => "VEC4",
            Kind::Mat4 => "MAT4",
        }
    }
}

impl Glb {
    /// `bytes` as a buffer view (4-byte aligned, as every accessor here needs); its index.
    pub fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let mut view = json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
        });
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(view);
        self.views.len() - 1
    }

    fn accessor(&mut self, accessor: Value) -> usize {
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// Floats, `kind.components()` to an element; with `bounds` the min and max glTF requires
    /// of positions.
    pub fn floats(&mut self, data: &[f32], kind: Kind, target: Option<u32>, bounds: bool) -> usize {
        let n = kind.components();
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, target);
        let mut accessor = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": data.len() / n,
            "type": kind.name(),
        });
        if bounds {
            let (mut lo, mut hi) = (vec![f32::MAX; n], vec![f32::MIN; n]);
            for element in data.chunks_exact(n) {
                for (c, &v) in element.iter().enumerate() {
                    lo[c] = lo[c].min(v);
                    hi[c] = hi[c].max(v);
                }
            }
            accessor["min"] = json!(lo);
            accessor["max"] = json!(hi);
        }
        self.accessor(accessor)
    }

    /// Joint indices, four to an element (`JOINTS_n`).
    pub fn joints(&mut self, data: &[[u8; 4]]) -> usize {
        let view = self.view(data.as_flattened(), Some(ARRAY_BUFFER));
        self.accessor(json!({
            "bufferView": view,
            "componentType": UNSIGNED_BYTE,
            "count": data.len(),
            "type": "VEC4",
        }))
    }

    /// Triangle indices.
    pub fn indices(&mut self, triangles: &[[u32; 3]]) -> usize {
        let bytes: Vec<u8> = triangles
            .as_flattened()
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessor(json!({
            "bufferView": view,
            "componentType": UNSIGNED_INT,
            "count": triangles.len() * 3,
            "type": "SCALAR",
        }))
    }

    /// `count` three-vectors, zero but at `indices` (ascending), where they are `values`: a
    /// sparse accessor (a morph target that moves only the face). The min and max cover the
    /// zeros too, as glTF requires of a morph target's positions.
    pub fn sparse_vec3(&mut self, count: usize, indices: &[u32], values: &[[f32; 3]]) -> usize {
        let index_bytes: Vec<u8> = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        let value_bytes: Vec<u8> = values
            .as_flattened()
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let index_view = self.view(&index_bytes, None);
        let value_view = self.view(&value_bytes, None);
        let (mut lo, mut hi) = ([0.0f32; 3], [0.0f32; 3]);
        for v in values {
            for c in 0..3 {
                lo[c] = lo[c].min(v[c]);
                hi[c] = hi[c].max(v[c]);
            }
        }
        self.accessor(json!({
            "componentType": FLOAT,
            "count": count,
            "type": "VEC3",
            "min": lo,
            "max": hi,
            "sparse": {
                "count": indices.len(),
                "indices": {"bufferView": index_view, "componentType": UNSIGNED_INT},
                "values": {"bufferView": value_view},
            },
        }))
    }

    /// Writes the file: `json` (without buffers, views and accessors, which are added here)
    /// and the binary chunk, to a temporary name, then renamed.
    pub fn write(mut self, path: &Path, mut json: Value) -> std::io::Result<()> {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        json["buffers"] = json!([{"byteLength": self.bin.len()}]);
        json["bufferViews"] = Value::Array(self.views);
        json["accessors"] = Value::Array(self.accessors);
        // Chunks are 4-byte aligned: JSON padded with spaces, the binary with zeros.
        let mut text = serde_json::to_vec(&json).map_err(std::io::Error::other)?;
        text.resize(text.len().next_multiple_of(4), b' ');
        let total = 12 + 8 + text.len() + 8 + self.bin.len();
        crate::atomic_file::write_atomic(path, |out| {
            out.write_all(b"glTF")?;
            out.write_all(&2u32.to_le_bytes())?;
            out.write_all(&(total as u32).to_le_bytes())?;
            out.write_all(&(text.len() as u32).to_le_bytes())?;
            out.write_all(b"JSON")?;
            out.write_all(&text)?;
            out.write_all(&(self.bin.len() as u32).to_le_bytes())?;
            out.write_all(b"BIN\0")?;
            out.write_all(&self.bin)
        })
    }
}
