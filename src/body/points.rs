//! Posing a few surface points instead of the whole mesh. The fit evaluates its residuals
//! thousands of times and needs only its landmarks, and a landmark (a weighted sum of vertices,
//! up to hundreds for Anny's COCO regressors) is linear in the joints' skinning transforms:
//! p = Σ_v w_v Σ_j s_vj A_j (x_v + Σ_t c_t δ_tv) = Σ_j A_j (m_j + Σ_t c_t d_jt) + W_j a_j,
//! with m_j = Σ_v w_v s_vj x_v, d_jt = Σ_v w_v s_vj δ_tv and W_j = Σ_v w_v s_vj summed once here.
//! [`PointPoser`] keeps those sums, so a point costs a few joints instead of its vertices, and
//! gives what [`BodyModel::pose`] gives up to float rounding.

use std::collections::BTreeMap;

use glam::{Affine3A, Mat3A, Vec3, Vec3A};

use super::lbs::{rigid_chain, rodrigues};
use super::{BodyModel, BodyPose, Landmark, PoseError};

/// One joint's share of one point.
struct Share {
    joint: usize,
    /// W_j: the point's total skin weight on the joint.
    weight: f32,
    /// m_j: the weighted rest positions.
    rest: Vec3,
    /// d_jt for the targets that move the point's vertices.
    deltas: Vec<(usize, Vec3)>,
}

pub struct PointPoser {
    points: Vec<Vec<Share>>,
    // Scratch, reused across calls.
    rest_joints: Vec<Vec3>,
    rotations: Vec<Mat3A>,
    world: Vec<Affine3A>,
    placements: Vec<Affine3A>,
}

impl PointPoser {
    pub fn new<'a>(body: &BodyModel, points: impl IntoIterator<Item = &'a Landmark>) -> Self {
        let points: Vec<&Landmark> = points.into_iter().collect();
        // Which targets move each vertex the points use, and by how much: a slot per used
        // vertex, found through a table over all vertices (the targets hold ~10⁵ deltas, and
        // a map lookup for each took a few milliseconds a fit; a video fits every frame).
        let mut slot = vec![u32::MAX; body.vertices.len()];
        let mut moved: Vec<Vec<(usize, Vec3)>> = Vec::new();
        for &v in points.iter().flat_map(|p| &p.vertices) {
            if slot[v as usize] == u32::MAX {
                slot[v as usize] = moved.len() as u32;
                moved.push(Vec::new());
            }
        }
        for (t, target) in body.targets.iter().enumerate() {
            for (v, &d) in target.vertices.iter().zip(&target.deltas) {
                if let Some(&k) = slot.get(*v as usize).filter(|&&k| k != u32::MAX) {
                    moved[k as usize].push((t, d));
                }
            }
        }
        let points = points
            .iter()
            .map(|p| {
                let mut shares: BTreeMap<usize, Share> = BTreeMap::new();
                for (&v, &w) in p.vertices.iter().zip(&p.weights) {
                    let (js, ss) = (
                        &body.skin_joints[v as usize],
                        &body.skin_weights[v as usize],
                    );
                    for (&j, &s) in js.iter().zip(ss).filter(|(_, s)| **s != 0.0) {
                        let share = shares.entry(j as usize).or_insert_with(|| Share {
                            joint: j as usize,
                            weight: 0.0,
                            rest: Vec3::ZERO,
                            deltas: Vec::new(),
                        });
                        share.weight += w * s;
                        share.rest += w * s * body.vertices[v as usize];
                        for &(t, d) in &moved[slot[v as usize] as usize] {
                            match share.deltas.iter_mut().find(|(k, _)| *k == t) {
                                Some((_, sum)) => *sum += w * s * d,
                                None => share.deltas.push((t, w * s * d)),
                            }
                        }
                    }
                }
                shares.into_values().collect()
            })
            .collect();
        Self {
            points,
            rest_joints: Vec::new(),
            rotations: Vec::new(),
            world: Vec::new(),
            placements: Vec::new(),
        }
    }

    /// The posed points (and, in `joints`, the posed joint positions) for `pose`, with the same
    /// conventions as [`BodyModel::pose`]; non-finite inputs are treated as zero.
    pub fn pose(
        &mut self,
        body: &BodyModel,
        pose: &BodyPose,
        points: &mut Vec<Vec3>,
        joints: &mut Vec<Vec3>,
    ) -> Result<(), PoseError> {
        pose.check_lengths(body.joints.len(), body.targets.len())?;
        let c = |t: usize| {
            let c = pose.coefficients[t];
            if c.is_finite() { c } else { 0.0 }
        };
        self.rest_joints.clear();
        self.rest_joints.extend(body.joints.iter().map(|j| j.rest));
        for (t, target) in body.targets.iter().enumerate() {
            if c(t) != 0.0 {
                for (j, &d) in self.rest_joints.iter_mut().zip(&target.joint_deltas) {
                    *j += c(t) * d;
                }
            }
        }
        let translation = if pose.translation.is_finite() {
            pose.translation
        } else {
            Vec3::ZERO
        };
        let mut nonfinite = 0;
        self.rotations.clear();
        self.rotations
            .extend(pose.rotations.iter().map(|&r| rodrigues(r, &mut nonfinite)));
        rigid_chain(
            body.joints.iter().map(|j| j.parent),
            &self.rest_joints,
            &self.rotations,
            translation,
            &mut self.world,
            &mut self.placements,
        );
        points.clear();
        points.extend(self.points.iter().map(|shares| {
            let mut p = Vec3A::ZERO;
            for s in shares {
                let a = &self.placements[s.joint];
                let mut x = s.rest;
                for &(t, d) in &s.deltas {
                    x += c(t) * d;
                }
                p += a.matrix3 * Vec3A::from(x) + s.weight * a.translation;
            }
            Vec3::from(p)
        }));
        joints.clear();
        joints.extend(self.world.iter().map(|w| Vec3::from(w.translation)));
        Ok(())
    }
}
