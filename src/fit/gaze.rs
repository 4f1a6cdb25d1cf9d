//! Where the eyes look: each eye joint turned so that the body's pupil lands on the iris the iris
//! model found. The pupil is the front of the eyeball's iris part (its vertex furthest forward in
//! the rest pose, where the body faces +z), which turns with the eye joint.

use crate::body::{BodyModel, Landmark};
use crate::keypoints::Side;

/// The eye joint of each side.
pub fn eye_joint(side: Side) -> &'static str {
    match side {
        Side::Left => "eye.L",
        Side::Right => "eye.R",
    }
}

/// The face-mesh feature (of [`super::FACE_FEATURES`]) an eye's iris moves with.
pub fn eye_feature(side: Side) -> &'static str {
    match side {
        Side::Left => "left eye",
        Side::Right => "right eye",
    }
}

/// The pupil of the `side` eye: the vertex furthest forward at rest of the part `eye_front.L` or
/// `.R` (the default body's iris and cornea); `None` for a body without that part.
pub fn pupil(body: &BodyModel, side: Side) -> Option<Landmark> {
    let part = match side {
        Side::Left => "eye_front.L",
        Side::Right => "eye_front.R",
    };
    let front = (0..body.vertices.len())
        .filter(|&v| body.part_of(v) == Some(part))
        .max_by(|&a, &b| body.vertices[a].z.total_cmp(&body.vertices[b].z))?;
    Some(Landmark {
        name: format!(
            "pupil_{}",
            if side == Side::Left { "left" } else { "right" }
        ),
        vertices: vec![front as u32],
        weights: vec![1.0],
    })
}
