//! Posing an avatar's Gaussians (reference: `ubody_gaussian.py:Ubody_Gaussian.forward`,
//! digested in notes/guava-pipeline.md §5):
//! - template Gaussian i: μ = posed vertex i, r = q(T_i) ⊗ r_local with T_i its blended skinning
//!   matrix (not orthonormalised, as roma's `rotmat_to_unitquat` takes it), renormalised;
//! - skinned Gaussian (ours, beyond the body): μ = Σ w_k v_k + S·Δμ, r = q(S) ⊗ r_local with S
//!   = Σ w_k S_k its vertices' blended skinning (linear parts), renormalised;
//! - UV Gaussian on triangle f: μ = σ_f·R_f·Δμ + Σ b_k v_k, r = q(R_f) ⊗ r_local, s = σ_f·s_local.

use std::sync::Arc;

use glam::{Mat3A, Vec3};

use super::{Avatar, Dressing, HandsInView};
use crate::body::{Posable, PosedBody, TriangleFrame, triangle_frames};
use crate::gaussians::GaussianCloud;

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error(
    "the avatar is bound to {body:?} ({expected_vertices} vertices, {expected_triangles} triangles) \
     but the posed body has {vertices} vertices and {triangles} triangles"
)]
pub struct BodyMismatch {
    pub body: String,
    pub expected_vertices: usize,
    pub expected_triangles: usize,
    pub vertices: usize,
    pub triangles: usize,
}

/// Scratch space for [`Rig::animate`], reused across frames (no allocation after the first),
/// and the avatar's hands the photo did not show, when they are drawn only in its view.
#[derive(Clone, Debug, Default)]
pub struct Rig {
    frames: Vec<TriangleFrame>,
    dressing: Dressing,
    hands: Option<Arc<HandsInView>>,
    visibility: Vec<f32>,
}

impl Rig {
    /// A rig that draws the hands the photo did not show only where it looked (`None`: as the
    /// avatar has them).
    pub fn with_hands(hands: Option<Arc<HandsInView>>) -> Self {
        Self {
            hands,
            ..Self::default()
        }
    }

    /// The avatar's Gaussians on `body` posed as `posed` (dressed in the avatar's clothing
    /// first), into `out`; not those on parts its photo did not show ([`Avatar::outside`]).
    pub fn animate(
        &mut self,
        avatar: &Avatar,
        posed: &PosedBody,
        body: &impl Posable,
        out: &mut GaussianCloud,
    ) -> Result<(), BodyMismatch> {
        let triangles = body.triangles();
        if posed.vertices.len() != avatar.body_vertices
            || posed.skin.len() != avatar.body_vertices
            || triangles.len() != avatar.body_triangles
        {
            return Err(BodyMismatch {
                body: avatar.body.clone(),
                expected_vertices: avatar.body_vertices,
                expected_triangles: avatar.body_triangles,
                vertices: posed.vertices.len(),
                triangles: triangles.len(),
            });
        }
        out.channels = avatar.channels;
        out.low_pass = avatar.kind.low_pass();
        out.positions.clear();
        out.rotations.clear();
        out.scales.clear();
        out.opacities.clear();
        out.features.clear();

        let vertices = self.dressing.apply(
            &avatar.displacements,
            &posed.vertices,
            triangles,
            body.weld(),
        );
        let t = &avatar.template;
        for ((v, skin), &r) in vertices.iter().zip(&posed.skin).zip(&t.rotations) {
            out.positions.push(v.to_array());
            out.rotations
                .push(normalize(quat_mul(quat_from_matrix(skin.matrix3), r)));
        }
        out.scales.extend_from_slice(&t.scales);
        self.visibility.clear();
        if let Some(hands) = &self.hands {
            hands.visibility(posed, &mut self.visibility);
        }
        let seen = |v: usize| self.visibility.get(v).copied().unwrap_or(1.0);
        out.opacities
            .extend(t.opacities.iter().enumerate().map(|(v, &o)| o * seen(v)));
        out.features.extend_from_slice(&t.features);

        let k = &avatar.skinned;
        for ((v, w), (offset, &r)) in k
            .vertices
            .iter()
            .zip(&k.weights)
            .zip(k.offsets.iter().zip(&k.local.rotations))
        {
            let (anchor, skin) = blend(v, w, vertices, posed);
            out.positions
                .push((anchor + skin * Vec3::from(*offset)).to_array());
            out.rotations
                .push(normalize(quat_mul(quat_from_matrix(skin), r)));
        }
        out.scales.extend_from_slice(&k.local.scales);
        out.opacities.extend_from_slice(&k.local.opacities);
        out.features.extend_from_slice(&k.local.features);

        triangle_frames(vertices, triangles, &mut self.frames);
        let uv = &avatar.uv;
        let shown = avatar.shown_uv(false);
        for (((&f, b), offset), (&r, s)) in uv
            .triangles
            .iter()
            .zip(&uv.barycentrics)
            .zip(&uv.offsets)
            .zip(uv.local.rotations.iter().zip(&uv.local.scales))
            .take(shown)
        {
            let frame = self.frames[f as usize];
            let [v0, v1, v2] = triangles[f as usize].map(|k| vertices[k as usize]);
            let anchor = b[0] * v0 + b[1] * v1 + b[2] * v2;
            let mu = frame.scale * (frame.rotation * Vec3::from(*offset)) + anchor;
            out.positions.push(mu.to_array());
            out.rotations
                .push(quat_mul(quat_from_matrix(Mat3A::from(frame.rotation)), r));
            out.scales.push(s.map(|x| x * frame.scale));
        }
        out.opacities
            .extend(
                uv.local.opacities[..shown]
                    .iter()
                    .zip(&uv.triangles)
                    .map(|(&o, &f)| {
                        let corners = triangles[f as usize].map(|k| seen(k as usize));
                        o * corners[0].min(corners[1]).min(corners[2])
                    }),
            );
        out.features
            .extend_from_slice(&uv.local.features[..shown * avatar.channels]);
        Ok(())
    }
}

/// The weighted mean of vertices `v` (`weights` w) of the dressed posed body and their blended
/// skinning's linear part: where a skinned Gaussian is anchored and what turns it.
pub fn blend(v: &[u32; 4], w: &[f32; 4], vertices: &[Vec3], posed: &PosedBody) -> (Vec3, Mat3A) {
    let mut anchor = Vec3::ZERO;
    let mut skin = Mat3A::ZERO;
    for (&k, &weight) in v.iter().zip(w) {
        anchor += weight * vertices[k as usize];
        skin += posed.skin[k as usize].matrix3 * weight;
    }
    (anchor, skin)
}

/// Hamilton product p ⊗ q of (w, x, y, z) quaternions.
pub fn quat_mul(p: [f32; 4], q: [f32; 4]) -> [f32; 4] {
    let (pw, pv) = (p[0], Vec3::new(p[1], p[2], p[3]));
    let (qw, qv) = (q[0], Vec3::new(q[1], q[2], q[3]));
    let v = pw * qv + qw * pv + pv.cross(qv);
    [pw * qw - pv.dot(qv), v.x, v.y, v.z]
}

fn normalize(q: [f32; 4]) -> [f32; 4] {
    let n = q.iter().map(|x| x * x).sum::<f32>().sqrt();
    if n > 0.0 && n.is_finite() {
        q.map(|x| x / n)
    } else {
        [1.0, 0.0, 0.0, 0.0]
    }
}

/// Unit quaternion (w, x, y, z) of a 3×3 matrix by Shepperd's method on the matrix as given
/// (roma's `rotmat_to_unitquat`): the largest of the diagonal and the trace picks the formula.
/// A zero or non-finite matrix gives the identity.
pub fn quat_from_matrix(m: Mat3A) -> [f32; 4] {
    let r = |i: usize, j: usize| m.col(j)[i];
    let trace = r(0, 0) + r(1, 1) + r(2, 2);
    let diag = [r(0, 0), r(1, 1), r(2, 2)];
    let (i, &largest) = diag
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .expect("three entries");
    let q = if trace >= largest {
        [
            1.0 + trace,
            r(2, 1) - r(1, 2),
            r(0, 2) - r(2, 0),
            r(1, 0) - r(0, 1),
        ]
    } else {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        let mut xyz = [0.0; 3];
        xyz[i] = 1.0 - trace + 2.0 * r(i, i);
        xyz[j] = r(j, i) + r(i, j);
        xyz[k] = r(k, i) + r(i, k);
        [r(k, j) - r(j, k), xyz[0], xyz[1], xyz[2]]
    };
    normalize(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat3;

    fn matrix_from_quat(q: [f32; 4]) -> Mat3 {
        Mat3::from_quat(glam::Quat::from_xyzw(q[1], q[2], q[3], q[0]))
    }

    #[test]
    fn matrix_quaternion_round_trip() {
        let mut rng = crate::gaussians::synthetic::Rng::new(3);
        for _ in 0..1000 {
            let q = rng.unit_quaternion();
            let back = quat_from_matrix(Mat3A::from(matrix_from_quat(q)));
            // q and −q are the same rotation.
            let d = q
                .iter()
                .zip(&back)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f32::max);
            let s = q
                .iter()
                .zip(&back)
                .map(|(a, b)| (a + b).abs())
                .fold(0.0, f32::max);
            assert!(d.min(s) < 1e-5, "{q:?} → {back:?}");
        }
        assert_eq!(quat_from_matrix(Mat3A::ZERO), [1.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn product_composes_rotations() {
        let mut rng = crate::gaussians::synthetic::Rng::new(4);
        let (p, q) = (rng.unit_quaternion(), rng.unit_quaternion());
        let composed = matrix_from_quat(quat_mul(p, q));
        let expected = matrix_from_quat(p) * matrix_from_quat(q);
        assert!(composed.abs_diff_eq(expected, 1e-5));
    }
}
