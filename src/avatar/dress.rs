//! The clothing an avatar wears over its body: per-vertex offsets along the posed body's smooth
//! normals (SMPL+D's displacement layer), so the surface the Gaussians ride on is the person's
//! outline, not the bare body's, in every pose.

use glam::Vec3;

use crate::body::vertex_normals;

/// Scratch space for dressing a posed body, reused across frames.
#[derive(Clone, Debug, Default)]
pub struct Dressing {
    normals: Vec<Vec3>,
    scratch: Vec<Vec3>,
    dressed: Vec<Vec3>,
}

impl Dressing {
    /// `vertices` (a posed body whose mesh is `triangles`, welded by `weld`) moved out by
    /// `displacements` (metres, one per vertex) along their smooth normals; `vertices` as they
    /// are when there are none.
    pub fn apply<'a>(
        &'a mut self,
        displacements: &[f32],
        vertices: &'a [Vec3],
        triangles: &[[u32; 3]],
        weld: Option<&[u32]>,
    ) -> &'a [Vec3] {
        if displacements.is_empty() {
            return vertices;
        }
        vertex_normals(
            vertices,
            triangles,
            weld,
            &mut self.scratch,
            &mut self.normals,
        );
        self.dressed.clear();
        self.dressed.extend(
            vertices
                .iter()
                .zip(&self.normals)
                .zip(displacements)
                .map(|((v, n), d)| *v + *n * *d),
        );
        &self.dressed
    }
}
