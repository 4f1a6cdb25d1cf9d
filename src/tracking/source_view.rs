//! The source view of a photo: the body's pose and GUAVA's camera that see it, and the square of
//! the photo that camera describes. A fit makes one, a tracking file's frame 0 holds one, and
//! reconstruction reads the photo through it.

use super::{BodyKind, EhmIdentityRecord, Frame, Retarget, TrackedCamera, Tracking, TrackingError};
use super::{camera_at, rig_of};
use crate::body::{BodyPose, Posable};
use crate::camera::Camera;
use crate::photo::{Crop, SOURCE_SIZE};

/// The tracked source: pose and camera of the photo, and the square of the photo the camera sees.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceView {
    pub pose: BodyPose,
    pub camera: Camera,
    /// `None`: the photo's centred square.
    pub crop: Option<Crop>,
}

/// `body`'s parameters split into identity (shape: a tracking file's `identity`) and the rest
/// (every frame's `values`), as indices.
fn split_parameters(body: &impl Posable) -> (Vec<usize>, Vec<usize>) {
    (0..body.parameter_names().len()).partition(|&i| body.is_identity_parameter(i))
}

impl SourceView {
    /// A one-frame tracking file for `body` holding this view exactly (what `guava fit` and the
    /// viewer's *Save as tracking* write): its rig's joints, its shape as identity (with EHM's
    /// skeleton for an EHM body), its other parameters as the frame's values, the camera;
    /// `source` says where it came from.
    pub fn to_tracking(&self, body: &impl Posable, source: &str) -> Tracking {
        let (identity, values) = split_parameters(body);
        let names: Vec<&str> = body.parameter_names().collect();
        let mut tracking = Tracking::new(
            rig_of(body).unwrap_or(BodyKind::Default),
            30.0,
            body.joint_names().map(String::from).collect(),
            values.iter().map(|&i| names[i].to_owned()).collect(),
        );
        tracking.source = source.into();
        for i in identity {
            if self.pose.coefficients[i] != 0.0 {
                let name = names[i].to_owned();
                tracking
                    .identity
                    .parameters
                    .insert(name, self.pose.coefficients[i]);
            }
        }
        tracking.identity.ehm = body.ehm_identity().map(EhmIdentityRecord::of);
        tracking.frames.push(self.to_frame(body));
        tracking
    }

    /// This view as one frame of a tracking file made by [`Self::to_tracking`] for `body`: the
    /// pose's translation, rotations and non-identity parameters, and the camera.
    pub fn to_frame(&self, body: &impl Posable) -> Frame {
        let (_, values) = split_parameters(body);
        let w2c: glam::Mat4 = self.camera.view_from_world;
        let rows = [0, 1, 2].map(|r| w2c.row(r).to_array());
        Frame {
            translation: self.pose.translation.to_array(),
            rotations: self.pose.rotations.iter().map(|r| r.to_array()).collect(),
            values: values.iter().map(|&i| self.pose.coefficients[i]).collect(),
            camera: Some(TrackedCamera {
                w2c: rows,
                invtanfov: self.camera.invtanfov(),
                crop: self.crop.map(Crop::to_array),
            }),
        }
    }

    /// Frame 0 of `tracking`, retargeted onto `body`; the camera is the frame's tracked camera at
    /// the source size. `file` names the tracking file in errors.
    pub fn from_tracking(
        tracking: &Tracking,
        body: &impl Posable,
        file: &str,
    ) -> Result<Self, TrackingError> {
        Self::at_frame(tracking, body, 0, file)
    }

    /// Frame `frame` of `tracking` as [`Self::from_tracking`] reads frame 0 (a tracked video's
    /// frames, for self-reenactment).
    pub fn at_frame(
        tracking: &Tracking,
        body: &impl Posable,
        frame: usize,
        file: &str,
    ) -> Result<Self, TrackingError> {
        let Some(tracked) = tracking.frames.get(frame) else {
            return Err(TrackingError {
                file: file.into(),
                frame: None,
                field: "frames".into(),
                problem: format!(
                    "has {} frames, frame {frame} was asked for",
                    tracking.frames.len()
                ),
            });
        };
        let time = frame as f64 / tracking.fps as f64;
        let (w2c, invtanfov) = camera_at(tracking, time)
            .filter(|_| tracked.camera.is_some())
            .ok_or_else(|| TrackingError {
                file: file.into(),
                frame: Some(frame),
                field: "camera".into(),
                problem: "missing (reconstruction needs the photo's tracked camera)".into(),
            })?;
        let mut pose = BodyPose::rest(body);
        Retarget::new(tracking, body).sample(tracking, time, &mut pose);
        // Validated on loading: the side is positive and every number within ±2²⁰.
        let crop = tracked
            .camera
            .and_then(|c| c.crop)
            .map(|[left, top, side]| Crop {
                left: left as i32,
                top: top as i32,
                side: side as u32,
            });
        Ok(Self {
            pose,
            camera: Camera::guava(w2c, SOURCE_SIZE, invtanfov),
            crop,
        })
    }
}
