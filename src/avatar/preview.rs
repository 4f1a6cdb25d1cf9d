//! A coarse stand-in of an avatar for frames drawn while the user drags, orbits or plays: one UV
//! Gaussian per triangle (per cell of offsets from it, for Gaussians standing off the surface) in
//! place of the (on average four or five) the avatar binds to it, at
//! their mean place with their mean features, enlarged by √n so it covers what the n covered;
//! no template Gaussians (they close cracks between UV islands, which the enlarged splats
//! cover). The splatting pass's per-Gaussian stages (projection, both sorts) cost in proportion
//! to the count, and on a CPU adapter they outweigh the pixels at any viewport size.

use std::collections::BTreeMap;

use super::{Avatar, LocalGaussians, SkinnedGaussians, UvGaussians};

/// Gaussians of one triangle are pooled when their offsets from it fall in the same cell of this
/// side (the triangle's local units: about metres).
const GROUP_CELL: f32 = 0.02;

impl Avatar {
    /// The coarse stand-in (see the module): same body, same channels, no template Gaussians.
    pub fn preview(&self) -> Avatar {
        let uv = &self.uv;
        let c = self.channels;
        // Groups: a triangle's Gaussians within one cell of their offsets from its surface, so
        // that those standing off it (hair and clothing beyond the body, bound to their nearest
        // triangle) are not pooled into one huge splat on the surface. Triangles the photo showed
        // first, then those it did not (they stay the trailing block).
        let first_outside = self.shown_uv(false);
        let mut groups: BTreeMap<(bool, u32, [i32; 3]), Vec<usize>> = BTreeMap::new();
        for (i, &t) in uv.triangles.iter().enumerate() {
            let cell = uv.offsets[i].map(|o| (o / GROUP_CELL).floor() as i32);
            groups
                .entry((i >= first_outside, t, cell))
                .or_default()
                .push(i);
        }
        let mut out = UvGaussians::default();
        let mut outside_count = 0;
        for ((outside, t, _), members) in groups {
            outside_count += usize::from(outside);

            let n = members.len() as f32;
            let mean = |get: &dyn Fn(usize) -> [f32; 3]| {
                members.iter().fold([0.0; 3], |acc, &i| {
                    let v = get(i);
                    [0, 1, 2].map(|k| acc[k] + v[k] / n)
                })
            };
            out.triangles.push(t);
            out.barycentrics.push(mean(&|i| uv.barycentrics[i]));
            out.offsets.push(mean(&|i| uv.offsets[i]));
            pool(&uv.local, c, &members, &mut out.local);
        }
        // Skinned Gaussians pooled alike, by their first vertex and a cell of their offsets.
        let k = &self.skinned;
        let mut groups: BTreeMap<(u32, [i32; 3]), Vec<usize>> = BTreeMap::new();
        for (i, v) in k.vertices.iter().enumerate() {
            let cell = k.offsets[i].map(|o| (o / GROUP_CELL).floor() as i32);
            groups.entry((v[0], cell)).or_default().push(i);
        }
        let mut skinned = SkinnedGaussians::default();
        for members in groups.into_values() {
            let n = members.len() as f32;
            skinned.vertices.push(k.vertices[members[0]]);
            skinned.weights.push(k.weights[members[0]]);
            skinned
                .offsets
                .push(members.iter().fold([0.0; 3], |acc, &i| {
                    [0, 1, 2].map(|a| acc[a] + k.offsets[i][a] / n)
                }));
            pool(&k.local, c, &members, &mut skinned.local);
        }
        Avatar {
            kind: self.kind,
            body: self.body.clone(),
            body_vertices: self.body_vertices,
            body_triangles: self.body_triangles,
            channels: self.channels,
            identity: self.identity.clone(),
            ehm_identity: self.ehm_identity.clone(),
            source: self.source.clone(),
            source_view: self.source_view.clone(),
            displacements: self.displacements.clone(),
            template: LocalGaussians::default(),
            uv: out,
            skinned,
            outside: outside_count,
        }
    }
}

/// One Gaussian for `members` of `local` (`c` channels) into `out`: the first one's rotation,
/// its scale enlarged by √n, the largest opacity, the mean features.
fn pool(local: &LocalGaussians, c: usize, members: &[usize], out: &mut LocalGaussians) {
    let (first, n) = (members[0], members.len() as f32);
    out.rotations.push(local.rotations[first]);
    out.scales.push(local.scales[first].map(|s| s * n.sqrt()));
    out.opacities.push(
        members
            .iter()
            .map(|&i| local.opacities[i])
            .fold(0.0, f32::max),
    );
    let start = out.features.len();
    out.features.resize(start + c, 0.0);
    for &i in members {
        for (acc, v) in out.features[start..]
            .iter_mut()
            .zip(&local.features[i * c..(i + 1) * c])
        {
            *acc += v / n;
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::avatar::{Avatar, AvatarKind, LocalGaussians, SkinnedGaussians, UvGaussians};

    #[test]
    fn one_splat_per_triangle_with_the_mean_colour_and_the_area_of_all() {
        let local = |n: usize, features: Vec<f32>| LocalGaussians {
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
            scales: vec![[0.1, 0.01, 0.1]; n],
            opacities: (0..n).map(|i| 0.5 + 0.1 * i as f32).collect(),
            features,
        };
        let avatar = Avatar {
            kind: AvatarKind::DefaultReconstruction,
            body: "b".into(),
            body_vertices: 3,
            body_triangles: 2,
            channels: 1,
            identity: Default::default(),
            ehm_identity: None,
            source: "s".into(),
            source_view: None,
            displacements: Vec::new(),
            template: local(3, vec![0.0; 3]),
            uv: UvGaussians {
                triangles: vec![1, 1, 1, 1],
                barycentrics: vec![
                    [1.0, 0.0, 0.0],
                    [0.0, 1.0, 0.0],
                    [0.0, 0.0, 1.0],
                    [1.0, 0.0, 0.0],
                ],
                offsets: vec![[0.0; 3]; 4],
                local: local(4, vec![0.0, 1.0, 2.0, 3.0]),
            },
            // Two beyond the body near vertex 0 pool; a third 5 cm off stays apart.
            skinned: SkinnedGaussians {
                vertices: vec![[0, 1, 0, 0], [0, 2, 0, 0], [0, 1, 0, 0]],
                weights: vec![[0.5, 0.5, 0.0, 0.0]; 3],
                offsets: vec![[0.001, 0.0, 0.0], [0.003, 0.0, 0.0], [0.051, 0.0, 0.0]],
                local: local(3, vec![2.0, 4.0, 8.0]),
            },
            outside: 0,
        };
        let p = avatar.preview();
        assert!(p.template.is_empty());
        assert_eq!(p.uv.triangles, vec![1]);
        assert_eq!(p.uv.local.features, vec![1.5]);
        assert_eq!(p.uv.barycentrics, vec![[0.5, 0.25, 0.25]]);
        assert_eq!(p.uv.local.scales, vec![[0.2, 0.02, 0.2]]);
        assert!((p.uv.local.opacities[0] - 0.8).abs() < 1e-6);
        assert_eq!(p.skinned.local.features, vec![3.0, 8.0]);
        assert!((p.skinned.offsets[0][0] - 0.002).abs() < 1e-7);
        assert_eq!(p.skinned.vertices[0], [0, 1, 0, 0]);
    }
}
