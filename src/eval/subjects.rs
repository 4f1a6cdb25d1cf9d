//! Fidelity with known answers: each synthetic subject ([`crate::synthetic::Subject`]) is
//! photographed from the front, reconstructed from that photo with its exact view, and the avatar
//! is compared with the subject itself drawn from the source view, from novel views (yaw ±30°,
//! ±60°, the side and the back) and in a new pose (the demo motion's wave, from the front and
//! from 60°).

use glam::Vec3;

use super::{EvalError, Metrics, compare, render_view};
use crate::body::{BodyModel, BodyPose};
use crate::photo::SourceImage;
use crate::pipeline::{Mode, Outcome, Photo, Pipeline, Tracked};
use crate::render::{HeadlessRenderer, SplatImage};
use crate::synthetic::{Material, Subject, subject_texture, upper_body_camera};
use crate::tracking::{Retarget, SourceView, demo_motion};

/// Where a subject is compared: its photo's view, turned views, a new pose.
pub const VIEWS: [(&str, f32, bool); 9] = [
    ("source", 0.0, false),
    ("yaw −30°", -30.0, false),
    ("yaw +30°", 30.0, false),
    ("yaw −60°", -60.0, false),
    ("yaw +60°", 60.0, false),
    ("yaw +90° (side)", 90.0, false),
    ("yaw 180° (back)", 180.0, false),
    ("new pose (wave)", 0.0, true),
    ("wave from +60°", 60.0, true),
];

/// What went wrong with a subject: reconstructing it, or comparing.
#[derive(Debug, thiserror::Error)]
pub enum SubjectError {
    #[error(transparent)]
    Reconstruct(#[from] crate::reconstruct::ReconstructError),
    #[error(transparent)]
    Eval(#[from] EvalError),
    #[error(transparent)]
    Pose(#[from] crate::body::PoseError),
    #[error(transparent)]
    Tracking(#[from] crate::tracking::TrackingError),
}

/// `subject`, coloured by `texture`, photographed from the front at rest and reconstructed by
/// `pipeline` (default mode, the exact view given).
pub fn reconstruct_subject(
    pipeline: &mut Pipeline,
    subject: &Subject,
    texture: impl Fn(Vec3, Material) -> [f32; 3],
) -> Result<Outcome, SubjectError> {
    let view = front_view(subject.body, BodyPose::rest(subject.body));
    reconstruct_subject_as(pipeline, subject, texture, view)
}

/// The front photo's view of a subject in `pose`: [`upper_body_camera`] from straight ahead.
pub fn front_view(body: &BodyModel, pose: BodyPose) -> SourceView {
    SourceView {
        pose,
        camera: upper_body_camera(body, 0.0),
        crop: None,
    }
}

/// [`reconstruct_subject`] photographed as `view` says (a pose with shape coefficients, another
/// camera), the view given to the reconstruction.
pub fn reconstruct_subject_as(
    pipeline: &mut Pipeline,
    subject: &Subject,
    texture: impl Fn(Vec3, Material) -> [f32; 3],
    view: SourceView,
) -> Result<Outcome, SubjectError> {
    let photo = subject.photo(&view.pose, &view.camera, texture)?;
    Ok(pipeline.reconstruct(
        Mode::Default(subject.body),
        Photo::Pixels {
            name: subject.name,
            pixels: photo,
            has_alpha: true,
        },
        Tracked::Given(view),
        &mut |_| true,
    )?)
}

/// `subject` reconstructed from its front photo ([`reconstruct_subject`]), then compared at
/// every [`VIEWS`] entry: one row of metrics each. `look` sees each view's truth and render.
pub fn score(
    renderer: &mut HeadlessRenderer,
    pipeline: &mut Pipeline,
    subject: &Subject,
    mut look: impl FnMut(&str, &SourceImage, &SplatImage),
) -> Result<Vec<Metrics>, SubjectError> {
    let body: &BodyModel = subject.body;
    let rest = BodyPose::rest(body);
    let outcome = reconstruct_subject(pipeline, subject, subject_texture)?;
    let motion = demo_motion()?;
    let mut wave = rest.clone();
    Retarget::new(&motion, body).sample(&motion, 6.45, &mut wave);
    let mut rows = Vec::new();
    for (name, yaw, new_pose) in VIEWS {
        let at = SourceView {
            pose: if new_pose { wave.clone() } else { rest.clone() },
            camera: upper_body_camera(body, yaw.to_radians()),
            crop: None,
        };
        let truth = subject.photo(&at.pose, &at.camera, subject_texture)?;
        let truth = SourceImage::from_rgba(&truth, true, subject.name)
            .map_err(crate::reconstruct::ReconstructError::from)?;
        let rendered = render_view(renderer, &outcome.avatar, body, &at)?;
        rows.push(compare(&rendered, &truth)?);
        look(name, &truth, &rendered);
    }
    Ok(rows)
}
