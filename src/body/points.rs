//! Posing a few surface points instead of the whole mesh. The fit evaluates its residuals
//! hundreds of times per step and needs only its landmarks: [`PointPoser`] keeps just the
//! vertices they blend, with their skin influences and the morph deltas that move them, and
//! poses them exactly as [`BodyModel::pose`] does.

use std::collections::HashMap;

use glam::{Affine3A, Mat3A, Vec3};

use super::lbs::{blend, rigid_chain, rodrigues};
use super::{BodyModel, BodyPose, Landmark, PoseError};

pub struct PointPoser {
    /// The mesh vertices the points use, with their rest positions.
    vertices: Vec<u32>,
    rest: Vec<Vec3>,
    /// Per target: (index into `vertices`, delta) for the vertices it moves.
    deltas: Vec<Vec<(usize, Vec3)>>,
    /// Per point: (index into `vertices`, weight).
    points: Vec<Vec<(usize, f32)>>,
    // Scratch, reused across calls.
    morphed: Vec<Vec3>,
    rest_joints: Vec<Vec3>,
    rotations: Vec<Mat3A>,
    world: Vec<Affine3A>,
    placements: Vec<Affine3A>,
}

impl PointPoser {
    pub fn new<'a>(body: &BodyModel, points: impl IntoIterator<Item = &'a Landmark>) -> Self {
        let mut local = HashMap::new();
        let mut vertices = Vec::new();
        let points: Vec<Vec<(usize, f32)>> = points
            .into_iter()
            .map(|p| {
                p.vertices
                    .iter()
                    .zip(&p.weights)
                    .map(|(&v, &w)| {
                        let k = *local.entry(v).or_insert_with(|| {
                            vertices.push(v);
                            vertices.len() - 1
                        });
                        (k, w)
                    })
                    .collect()
            })
            .collect();
        let deltas = body
            .targets
            .iter()
            .map(|t| {
                t.vertices
                    .iter()
                    .zip(&t.deltas)
                    .filter_map(|(v, &d)| local.get(v).map(|&k| (k, d)))
                    .collect()
            })
            .collect();
        Self {
            rest: vertices
                .iter()
                .map(|&v| body.vertices[v as usize])
                .collect(),
            vertices,
            deltas,
            points,
            morphed: Vec::new(),
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
        let mut nonfinite = 0;
        self.morphed.clone_from(&self.rest);
        self.rest_joints.clear();
        self.rest_joints.extend(body.joints.iter().map(|j| j.rest));
        for ((target, deltas), &c) in body
            .targets
            .iter()
            .zip(&self.deltas)
            .zip(&pose.coefficients)
        {
            if c == 0.0 || !c.is_finite() {
                continue;
            }
            for &(k, d) in deltas {
                self.morphed[k] += c * d;
            }
            for (j, &d) in self.rest_joints.iter_mut().zip(&target.joint_deltas) {
                *j += c * d;
            }
        }
        let translation = if pose.translation.is_finite() {
            pose.translation
        } else {
            Vec3::ZERO
        };
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
        for (m, &v) in self.morphed.iter_mut().zip(&self.vertices) {
            let (js, ws) = (
                &body.skin_joints[v as usize],
                &body.skin_weights[v as usize],
            );
            let influences = js.iter().zip(ws).filter(|(_, w)| **w != 0.0);
            let skin = blend(influences.map(|(&j, &w)| (j as usize, w)), &self.placements);
            *m = skin.transform_point3(*m);
        }
        points.clear();
        points.extend(
            self.points
                .iter()
                .map(|p| p.iter().map(|&(k, w)| w * self.morphed[k]).sum::<Vec3>()),
        );
        joints.clear();
        joints.extend(self.world.iter().map(|w| Vec3::from(w.translation)));
        Ok(())
    }
}
