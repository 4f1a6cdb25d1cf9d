//! Smooth vertex normals of a posed body, for the shaded mesh view.

use glam::Vec3;

/// Area-weighted normals, shared across UV seams through `weld` so seams do not show as creases.
/// `scratch` holds one sum per welded vertex and is reused across frames.
pub fn vertex_normals(
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    weld: &[u32],
    scratch: &mut Vec<Vec3>,
    out: &mut Vec<Vec3>,
) {
    let groups = weld.iter().max().map_or(0, |&m| m as usize + 1);
    scratch.clear();
    scratch.resize(groups, Vec3::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        let n = (b - a).cross(c - a);
        if n.is_finite() {
            for &i in t {
                scratch[weld[i as usize] as usize] += n;
            }
        }
    }
    out.clear();
    out.extend(
        weld.iter()
            .map(|&w| scratch[w as usize].normalize_or_zero()),
    );
}
