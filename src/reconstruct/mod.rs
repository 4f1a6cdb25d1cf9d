//! Reconstruction from one photo (paper Sec. 3): the tracked source pose and camera, the photo,
//! and the body model in; an animatable [`Avatar`] out.
//!
//! Stages, each timed: pose the body in the source pose → rasterize it from the source camera
//! (z-buffer, and the person mask when the photo has no alpha) → inverse texture mapping of the
//! photo into the body's UV map with per-texel visibility → fill what the camera did not see
//! (default mode) → Gaussians bound to the surface.
//!
//! This is the **default reconstruction** (no GUAVA weights; the learned decoders plug in after
//! the same inverse texture mapping in GUAVA mode).

pub mod default_mode;
pub mod fill;
pub mod framing;
pub mod raster;
pub mod source;
pub mod synthetic;
pub mod texture;
pub mod uv_map;

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use crate::avatar::Avatar;
use crate::body::{BodyModel, BodyPose, Posable, PoseError, PosedBody, TargetGroup};
use crate::camera::Camera;
use crate::fit::FitReport;
use crate::keypoints::Landmarkers;
use crate::tracking::{
    BodyKind, EhmIdentityRecord, Frame, Retarget, TrackedCamera, Tracking, TrackingError, camera_at,
};
pub use default_mode::{DEFAULT_CHANNELS, DiscStyle};
pub use source::{Crop, SOURCE_SIZE, SourceImage};
pub use uv_map::UvMap;

/// The default reconstruction's UV map side: at 448² the Anny body has ~126k valid texels, which
/// with its 15,066 template Gaussians stays under GUAVA's ~150k total.
pub const DEFAULT_UV_SIZE: u32 = 448;

#[derive(Debug, thiserror::Error)]
pub enum ReconstructError {
    #[error("{file}: {problem}")]
    Image { file: String, problem: String },
    #[error("{file}: {problem}")]
    Tracking { file: String, problem: String },
    #[error(
        "the tracked camera sees none of the body's surface in the photo (is the tracking file the \
         photo's, and does the photo show the person?)"
    )]
    NothingVisible,
    #[error(transparent)]
    TrackingFile(#[from] TrackingError),
    #[error(transparent)]
    Pose(#[from] PoseError),
    #[error("pose model: {0}")]
    Keypoints(String),
    #[error("{0}")]
    Models(String),
    #[error("GUAVA models: {0}")]
    Network(#[from] crate::onnx::OnnxError),
    #[error("cancelled")]
    Cancelled,
}

/// The stages, in order, for progress reports and timings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Keypoints and mask from the pose model, and the fit (photos without tracking or alpha).
    Fit,
    /// GUAVA mode: DINOv2 and its feature head on the photo.
    Encode,
    Pose,
    Rasterize,
    TextureMap,
    Fill,
    /// GUAVA mode: the template-Gaussian decoder.
    DecodeVertices,
    /// GUAVA mode: the UV StyleUNet and its Gaussian heads.
    DecodeUv,
    Gaussians,
}

impl Stage {
    /// The stages of [`reconstruct_default`] (fitting comes before them, when it runs).
    pub const ALL: [Stage; 5] = [
        Stage::Pose,
        Stage::Rasterize,
        Stage::TextureMap,
        Stage::Fill,
        Stage::Gaussians,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Fit => "keypoints, mask and fit",
            Stage::Encode => "encoder (DINOv2, feature maps)",
            Stage::DecodeVertices => "template-Gaussian decoder",
            Stage::DecodeUv => "UV decoder (StyleUNet)",
            Stage::Pose => "pose source body",
            Stage::Rasterize => "rasterize (visibility, mask)",
            Stage::TextureMap => "inverse texture mapping",
            Stage::Fill => "fill (mirror, push-pull)",
            Stage::Gaussians => "build Gaussians",
        }
    }
}

/// What a reconstruction reports besides the avatar.
#[derive(Clone, Debug, Default)]
pub struct Report {
    pub timings: Vec<(Stage, Duration)>,
    pub texels: usize,
    pub observed: usize,
    pub mirrored: usize,
    pub mask: MaskSource,
    /// How the pose and camera were fitted, when they were.
    pub fit: Option<FitReport>,
    /// The pose model's body keypoints on the source image, when it ran.
    pub keypoints: Vec<crate::keypoints::Keypoint>,
}

/// The tracked source: pose and camera of the photo, and the square of the photo the camera sees.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceView {
    pub pose: BodyPose,
    pub camera: Camera,
    /// `None`: the photo's centred square.
    pub crop: Option<Crop>,
}

impl SourceView {
    /// A one-frame tracking file for `body` holding this view exactly (what `guava fit` and the
    /// viewer's *Save as tracking* write): its rig's joints, its shape as identity (with EHM's
    /// skeleton for an EHM body), its other parameters as the frame's values, the camera;
    /// `source` says where it came from.
    pub fn to_tracking(&self, body: &impl Posable, source: &str) -> Tracking {
        let view = self;
        let (identity, values): (Vec<usize>, Vec<usize>) =
            (0..body.parameter_names().len()).partition(|&i| body.is_identity_parameter(i));
        let names: Vec<&str> = body.parameter_names().collect();
        let mut tracking = Tracking::new(
            crate::tracking::rig_of(body).unwrap_or(BodyKind::Default),
            30.0,
            body.joint_names().map(String::from).collect(),
            values.iter().map(|&i| names[i].to_owned()).collect(),
        );
        tracking.source = source.into();
        for i in identity {
            if view.pose.coefficients[i] != 0.0 {
                let name = names[i].to_owned();
                tracking
                    .identity
                    .parameters
                    .insert(name, view.pose.coefficients[i]);
            }
        }
        tracking.identity.ehm = body.ehm_identity().map(EhmIdentityRecord::of);
        let w2c: glam::Mat4 = view.camera.view_from_world;
        let rows = [0, 1, 2].map(|r| w2c.row(r).to_array());
        tracking.frames.push(Frame {
            translation: view.pose.translation.to_array(),
            rotations: view.pose.rotations.iter().map(|r| r.to_array()).collect(),
            values: values.iter().map(|&i| view.pose.coefficients[i]).collect(),
            camera: Some(TrackedCamera {
                w2c: rows,
                invtanfov: view.camera.invtanfov(),
                crop: view.crop.map(Crop::to_array),
            }),
        });
        tracking
    }

    /// Frame 0 of `tracking`, retargeted onto `body`; the camera is the frame's tracked camera at
    /// the source size. `file` names the tracking file in errors.
    pub fn from_tracking(
        tracking: &Tracking,
        body: &impl Posable,
        file: &str,
    ) -> Result<Self, ReconstructError> {
        if tracking.frames.is_empty() {
            return Err(ReconstructError::Tracking {
                file: file.into(),
                problem: "has no frame".into(),
            });
        }
        let (w2c, invtanfov) =
            camera_at(tracking, 0.0).ok_or_else(|| ReconstructError::Tracking {
                file: file.into(),
                problem:
                    "frame 0: camera: missing (reconstruction needs the photo's tracked camera)"
                        .into(),
            })?;
        let mut pose = BodyPose::rest(body);
        Retarget::new(tracking, body).sample(tracking, 0.0, &mut pose);
        // Validated on loading: the side is positive and every number within ±2²⁰.
        let crop = tracking.frames[0]
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

/// The identity coefficients of `pose` (the shape targets it sets), stored with the avatar.
fn identity_of(body: &BodyModel, pose: &BodyPose) -> BTreeMap<String, f32> {
    body.targets_in(TargetGroup::Shape)
        .filter(|(i, _)| pose.coefficients[*i] != 0.0)
        .map(|(i, t)| (t.name.clone(), pose.coefficients[i]))
        .collect()
}

/// Default reconstruction of `photo` seen from `view`. `uv` is the body's UV map (built once per
/// body, [`UvMap::for_body`]). `progress` hears each stage as it starts and returns `false` to
/// cancel. `source_name` is stored with the avatar.
pub fn reconstruct_default(
    body: &BodyModel,
    uv: &UvMap,
    view: &SourceView,
    mut photo: SourceImage,
    source_name: &str,
    progress: &mut dyn FnMut(Stage) -> bool,
) -> Result<(Avatar, Report), ReconstructError> {
    let mut report = Report {
        texels: uv.len(),
        mask: if photo.mask.is_some() {
            MaskSource::Alpha
        } else {
            MaskSource::Silhouette
        },
        ..Default::default()
    };
    let mut clock = StageClock::default();
    let camera = &view.camera;

    clock.start(Stage::Pose, progress)?;
    let mut posed = PosedBody::default();
    body.pose(&view.pose, &mut posed)?;

    clock.start(Stage::Rasterize, progress)?;
    let fragments = raster::rasterize(&posed.vertices, &body.triangles, camera);
    if photo.mask.is_none() {
        photo.apply_mask(fragments.coverage());
    }

    clock.start(Stage::TextureMap, progress)?;
    let sampled = texture::inverse_texture_map(
        uv,
        &posed.vertices,
        &body.triangles,
        camera,
        &photo,
        &fragments,
    );
    report.observed = sampled.observed();

    clock.start(Stage::Fill, progress)?;
    let filled = fill::fill(uv, &sampled).ok_or(ReconstructError::NothingVisible)?;
    report.mirrored = filled
        .source
        .iter()
        .filter(|&&s| s == fill::FillSource::Mirrored)
        .count();

    clock.start(Stage::Gaussians, progress)?;
    let avatar = default_mode::build(
        body,
        &posed,
        uv,
        &filled,
        &DiscStyle::default(),
        identity_of(body, &view.pose),
        source_name.into(),
    );
    report.timings = clock.finish();
    Ok((avatar, report))
}

/// The tracking file that goes with a photo when none is named: same folder and stem, `.json`.
pub fn tracking_beside(photo: &std::path::Path) -> std::path::PathBuf {
    photo.with_extension("json")
}

/// How the photo's pose and camera are known.
pub enum Tracked<'a> {
    /// A tracking file (frame 0).
    File(&'a std::path::Path),
    /// Fitted here to the keypoint models' points.
    Fit,
    /// Given as it is (a fit adjusted by hand in the viewer).
    Given(SourceView),
}

/// Where the person mask came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MaskSource {
    /// The photo's alpha channel.
    #[default]
    Alpha,
    /// The pose model's person segmentation.
    Segmentation,
    /// The tracked body's silhouette (no alpha and no pose model).
    Silhouette,
}

/// Reads `photo`, gets its pose and camera (from a tracking file or by fitting keypoints), and
/// runs [`reconstruct_default`] on `body`: what the CLI and the viewer's worker call. A fitted
/// photo is framed around the person when its centred square will not do
/// ([`framing::Framing::KeepCentred`]); a tracked one is read in its tracking's square. A photo without alpha is masked by the pose model's segmentation when `landmarkers`
/// are given (else by the body's silhouette). Fitting needs `landmarkers`. Every error names the
/// file.
pub fn reconstruct_photo_file(
    body: &BodyModel,
    uv: &UvMap,
    photo: &std::path::Path,
    tracked: Tracked,
    mut landmarkers: Option<&mut Landmarkers>,
    progress: &mut dyn FnMut(Stage) -> bool,
) -> Result<(Avatar, Report, SourceView), ReconstructError> {
    let file = photo.display().to_string();
    let started = Instant::now();
    // A given pose runs the pose model too, so the viewer can show its keypoints against the pose.
    let points = matches!(tracked, Tracked::Given(_));
    let given = match tracked {
        Tracked::File(path) => {
            let name = path.display().to_string();
            Some(SourceView::from_tracking(
                &Tracking::load(path)?,
                body,
                &name,
            )?)
        }
        Tracked::Given(view) => Some(view),
        Tracked::Fit => None,
    };
    use framing::{Framing, Square};
    let read = framing::SourcePhoto::read(
        photo,
        given
            .as_ref()
            .map_or(Square::Fitted(Framing::KeepCentred), |v| Square::Tracked {
                crop: v.crop,
                points,
            }),
        landmarkers.as_deref_mut(),
        progress,
    )?;
    let mut image = read.image;
    let mut mask = MaskSource::Alpha;
    if image.mask.is_none() {
        if let Some(k) = &read.detections {
            image.apply_mask(k.pose.mask_at(image.size as usize));
            mask = MaskSource::Segmentation;
        } else {
            mask = MaskSource::Silhouette;
        }
    }
    let (view, fit) = match given {
        Some(view) => (view, None),
        None => {
            let k = read
                .detections
                .as_ref()
                .expect("a fitted photo's keypoints");
            let models = landmarkers.expect("the keypoints came from them");
            let (mut view, report) =
                crate::fit::fit_detections(body, k, &mut models.face, image.size)
                    .map_err(|e| fit_error(&file, e))?;
            view.crop = read.crop;
            (view, Some(report))
        }
    };
    let fit_time = started.elapsed();
    let name = photo
        .file_name()
        .map_or_else(|| file.clone(), |n| n.to_string_lossy().into_owned());
    let (avatar, mut report) = reconstruct_default(body, uv, &view, image, &name, progress)?;
    report.mask = mask;
    if read.detections.is_some() {
        report.timings.insert(0, (Stage::Fit, fit_time));
    }
    report.fit = fit;
    report.keypoints = read
        .detections
        .map(|k| k.pose.keypoints)
        .unwrap_or_default();
    Ok((avatar, report, view))
}

/// A failed fit of the photo `file`, as the reconstruction reports it.
pub(crate) fn fit_error(file: &str, e: crate::fit::FitError) -> ReconstructError {
    ReconstructError::Image {
        file: file.into(),
        problem: match e {
            crate::fit::FitError::NoPerson { .. } => format!("{e}; give the photo's tracking file"),
            e => e.to_string(),
        },
    }
}

/// Times consecutive stages and asks the progress callback whether to go on.
#[derive(Default)]
pub(crate) struct StageClock {
    current: Option<(Stage, Instant)>,
    done: Vec<(Stage, Duration)>,
}

impl StageClock {
    pub(crate) fn start(
        &mut self,
        stage: Stage,
        progress: &mut dyn FnMut(Stage) -> bool,
    ) -> Result<(), ReconstructError> {
        self.stop();
        if !progress(stage) {
            return Err(ReconstructError::Cancelled);
        }
        self.current = Some((stage, Instant::now()));
        Ok(())
    }

    fn stop(&mut self) {
        if let Some((stage, t)) = self.current.take() {
            self.done.push((stage, t.elapsed()));
        }
    }

    pub(crate) fn finish(mut self) -> Vec<(Stage, Duration)> {
        self.stop();
        self.done
    }
}
