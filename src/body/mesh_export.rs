//! A posed body as a binary glTF 2.0 file (`.glb`): one mesh of positions, normals and
//! triangles, in metres with y up (glTF's own axes, and the body's), written atomically. Other
//! tools (Blender, three.js viewers) open it.

use std::io::Write;
use std::path::Path;

use glam::Vec3;

/// Writes `positions`, `normals` (one per position) and `triangles` as one glTF mesh.
pub fn write_glb(
    path: &Path,
    positions: &[Vec3],
    normals: &[Vec3],
    triangles: &[[u32; 3]],
) -> std::io::Result<()> {
    assert_eq!(positions.len(), normals.len(), "a normal per position");
    let (lo, hi) = positions
        .iter()
        .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let mut bin = Vec::with_capacity(positions.len() * 24 + triangles.len() * 12);
    for v in positions.iter().chain(normals) {
        for c in v.to_array() {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in triangles.iter().flatten() {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let (n, t) = (positions.len(), triangles.len());
    let vertex_bytes = n * 12;
    let json = format!(
        r#"{{"asset":{{"version":"2.0","generator":"guava-rs"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"name":"posed body"}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}},"indices":2,"mode":4}}]}}],"buffers":[{{"byteLength":{len}}}],"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{vertex_bytes},"target":34962}},{{"buffer":0,"byteOffset":{vertex_bytes},"byteLength":{vertex_bytes},"target":34962}},{{"buffer":0,"byteOffset":{index_offset},"byteLength":{index_bytes},"target":34963}}],"accessors":[{{"bufferView":0,"componentType":5126,"count":{n},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}},{{"bufferView":1,"componentType":5126,"count":{n},"type":"VEC3"}},{{"bufferView":2,"componentType":5125,"count":{indices},"type":"SCALAR"}}]}}"#,
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z,
        len = bin.len(),
        index_offset = 2 * vertex_bytes,
        index_bytes = t * 12,
        indices = t * 3,
    );
    // Chunks are 4-byte aligned: JSON padded with spaces, the binary with zeros.
    let mut json = json.into_bytes();
    json.resize(json.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    crate::atomic_file::write_atomic(path, |out| {
        out.write_all(b"glTF")?;
        out.write_all(&2u32.to_le_bytes())?;
        out.write_all(&(total as u32).to_le_bytes())?;
        out.write_all(&(json.len() as u32).to_le_bytes())?;
        out.write_all(b"JSON")?;
        out.write_all(&json)?;
        out.write_all(&(bin.len() as u32).to_le_bytes())?;
        out.write_all(b"BIN\0")?;
        out.write_all(&bin)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_written_mesh_reads_back_through_the_gltf_crate() {
        let positions = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.5)];
        let normals = [Vec3::Z; 4];
        let triangles = [[0, 1, 2], [1, 3, 2]];
        let path = std::env::temp_dir().join(format!("guava-mesh-{}.glb", std::process::id()));
        write_glb(&path, &positions, &normals, &triangles).expect("written");
        let glb = gltf::Gltf::from_slice(&std::fs::read(&path).expect("read")).expect("glTF");
        let primitive = glb
            .meshes()
            .next()
            .expect("mesh")
            .primitives()
            .next()
            .expect("one");
        let reader = primitive.reader(|_| glb.blob.as_deref());
        let read: Vec<[f32; 3]> = reader.read_positions().expect("positions").collect();
        assert_eq!(read, positions.map(|p| p.to_array()));
        let normals_read: Vec<[f32; 3]> = reader.read_normals().expect("normals").collect();
        assert_eq!(normals_read, vec![[0.0, 0.0, 1.0]; 4]);
        let indices: Vec<u32> = reader.read_indices().expect("indices").into_u32().collect();
        assert_eq!(indices, [0, 1, 2, 1, 3, 2]);
        std::fs::remove_file(&path).ok();
    }
}
