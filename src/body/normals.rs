//! Smooth vertex normals of a posed body: the shaded mesh view lights with them, and an avatar's
//! clothing stands off the body along them.

use glam::Vec3;

/// Area-weighted normals, shared across UV seams through `weld` (each vertex's welded vertex,
/// [`super::Posable::weld`]; `None`: no seams split) so seams do not show as creases. `scratch`
/// holds one sum per welded vertex and is reused across frames.
pub fn vertex_normals(
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    weld: Option<&[u32]>,
    scratch: &mut Vec<Vec3>,
    out: &mut Vec<Vec3>,
) {
    let group = |i: usize| weld.map_or(i, |w| w[i] as usize);
    let groups = weld.map_or(vertices.len(), |w| {
        w.iter().max().map_or(0, |&m| m as usize + 1)
    });
    scratch.clear();
    scratch.resize(groups, Vec3::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        let n = (b - a).cross(c - a);
        if n.is_finite() {
            for &i in t {
                scratch[group(i as usize)] += n;
            }
        }
    }
    out.clear();
    out.extend((0..vertices.len()).map(|i| scratch[group(i)].normalize_or_zero()));
}
