//! What the viewer opens: each file (dropped, picked or named on the command line) routed by its
//! type to the job that loads it, and what the job loaded taken into the document — or, on any
//! error, reported by file with what is open kept as it is. Taking something in answers with
//! what the view should now show ([`Taken`]); the document never reaches into the view.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use guava::avatar::Avatar;
use guava::body::{BodyModel, BodyPose, EhmModel, Posable};
use guava::gaussians::GaussianCloud;
use guava::guava_mode::GuavaModels;
use guava::pipeline::{Photo, Tracked};
use guava::render::splatter::max_gaussians;
use guava::tracking::SourceView;
use guava::tracking::import::{Imported, open_motion};

use crate::avatar_view::AvatarState;
use crate::body_panel::BodyState;
use crate::document::{Document, Networks, Scene};
use crate::ids::next_id;
use crate::jobs::{JobContext, Loaded, LoadedAvatar, PhotoJob, Work};
use crate::motion::Motion;
use crate::viewing::{CameraMode, View};
use guava::body::AnyBody;

/// The shipped demo portrait (scikit-image's astronaut, public domain), with its fitted tracking
/// beside it (`assets/demo_portrait.json`, written by `guava fit`).
pub fn demo_portrait() -> PathBuf {
    PathBuf::from(guava::DEMO_PORTRAIT)
}

/// The name the synthetic demo photo goes by in the UI and in the avatar it makes.
const SYNTHETIC_PHOTO: &str = "synthetic photo of the default body (known-answer demo)";

pub(crate) fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// A job that opens something: the file it works on, the stage shown first, and the work.
pub(crate) struct Opening {
    pub path: PathBuf,
    pub stage: &'static str,
    pub work: Box<Work<Loaded>>,
}

impl Opening {
    fn new(
        path: PathBuf,
        stage: &'static str,
        work: impl FnOnce(&JobContext) -> Result<Loaded, String> + Send + 'static,
    ) -> Self {
        Self {
            path,
            stage,
            work: Box::new(work),
        }
    }
}

/// What taking something in asks of the view: what to show, whether to frame it, where to look
/// from; and the status line.
pub(crate) struct Taken {
    pub status: String,
    pub show: Option<View>,
    pub frame: bool,
    pub camera: Option<CameraMode>,
}

impl Taken {
    fn show(status: String, show: View, frame: bool) -> Self {
        Self {
            status,
            show: Some(show),
            frame,
            camera: None,
        }
    }

    /// Only a status line: the view stays as it is.
    fn status(status: String) -> Self {
        Self {
            status,
            show: None,
            frame: false,
            camera: None,
        }
    }
}

/// The job that opens `path` (a file or GUAVA's networks folder), routed by its type; or why it
/// cannot open.
pub(crate) fn opening(
    path: PathBuf,
    doc: &Document,
    photo: Option<PhotoJob>,
) -> Result<Opening, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if path.is_dir()
        && guava::keypoints::WHOLEBODY_FILES
            .iter()
            .all(|f| path.join(f).is_file())
    {
        return Ok(wholebody(path, doc));
    }
    if matches!(ext.as_deref(), Some("png" | "jpg" | "jpeg")) {
        // Its tracking file beside it, if there is one; otherwise the pose is fitted.
        let tracked = Tracked::beside(&path);
        return reconstruction(path, tracked, photo);
    }
    let file = path.clone();
    let opening = match ext.as_deref() {
        _ if path.is_dir() => Opening::new(path, "loading GUAVA's networks", move |_| {
            guava::onnx::OnnxRuntime::load()
                .map_err(|e| e.to_string())
                .and_then(|rt| GuavaModels::load_dir(rt, &file).map_err(|e| e.to_string()))
                .map(|m| Loaded::Networks(Box::new(m)))
        }),
        Some("ply" | "splat") => Opening::new(path, "reading", move |_| {
            guava::gaussians::read_file(&file)
                .map(Loaded::Cloud)
                .map_err(|e| e.to_string())
        }),
        Some("glb") => Opening::new(path, "reading", move |_| {
            BodyModel::load(&file)
                .map(|m| Loaded::Body(AnyBody::Template(Arc::new(m))))
                .map_err(|e| e.to_string())
        }),
        Some("npz") => Opening::new(path, "reading", move |_| open_npz(&file)),
        Some("json" | "csv") => Opening::new(path, "reading", move |_| {
            open_motion(&file)
                .map(Loaded::Motion)
                .map_err(|e| e.to_string())
        }),
        Some("guava") => Opening::new(path, "reading", move |_| {
            Avatar::load(&file)
                .map(|a| Loaded::Avatar(Box::new(LoadedAvatar::file(a))))
                .map_err(|e| e.to_string())
        }),
        _ => {
            return Err(format!(
                "{}: unsupported file type (open a 3DGS .ply, a body template .glb, an EHM \
                 body .npz, GUAVA's networks folder, an avatar .guava, a photo .png/.jpg with \
                 its tracking .json, or a motion: tracking .json, ARKit .csv, SMPL-X .npz)",
                path.display()
            ));
        }
    };
    Ok(opening)
}

/// Loads EHM-Tracker's keypoint models folder into the session's pipeline (so the next photo
/// does not load them again); once it loads, photos are fitted with its body and hand points.
pub(crate) fn wholebody(dir: PathBuf, doc: &Document) -> Opening {
    let (worker_dir, pipeline) = (dir.clone(), doc.pipeline.clone());
    Opening::new(dir, "loading EHM-Tracker's keypoint models", move |_| {
        let mut pipeline = pipeline.lock().unwrap_or_else(|e| e.into_inner());
        pipeline.keypoints.set_dwpose(Some(worker_dir.clone()));
        pipeline.landmarkers()?;
        Ok(Loaded::Wholebody(worker_dir))
    })
}

/// Makes an avatar of the photo at `path`: the default reconstruction on a body template,
/// GUAVA's on EHM.
pub(crate) fn reconstruction(
    path: PathBuf,
    tracked: Tracked,
    job: Option<PhotoJob>,
) -> Result<Opening, String> {
    let job = job.ok_or("no body to reconstruct on")?;
    let photo = path.clone();
    Ok(Opening::new(path, "reading", move |context| {
        job.run(Photo::File(&photo), tracked, context)
    }))
}

/// Reconstructs a synthetic photo of the current body (the known-answer demo: the body with a
/// colour pattern, drawn from GUAVA's camera), so a fresh install can make an avatar offline.
pub(crate) fn synthetic_reconstruction(job: Option<PhotoJob>) -> Result<Opening, String> {
    use guava::synthetic;
    let job = job.ok_or("no body to reconstruct on")?;
    let model = job.body.template().ok_or(
        "the default reconstruction works on a body template; the current body is EHM (GUAVA \
         mode): Mode > Default body first",
    )?;
    let view = SourceView {
        pose: BodyPose::rest(model),
        camera: synthetic::upper_body_camera(model, 0.35),
        crop: None,
    };
    Ok(Opening::new(
        SYNTHETIC_PHOTO.into(),
        "drawing the synthetic photo",
        move |context| {
            let model = job.body.template().ok_or("the body is a template")?;
            let pixels =
                synthetic::photo(model, &view.pose, &view.camera, synthetic::banded_texture)
                    .map_err(|e| e.to_string())?;
            let photo = Photo::Pixels {
                name: SYNTHETIC_PHOTO,
                pixels,
                has_alpha: true,
            };
            job.run(photo, Tracked::Given(view), context)
        },
    ))
}

impl Document {
    /// What a photo's reconstruction needs from the document (`None` without a body), with the
    /// device to compare the avatar with its photo on.
    pub(crate) fn photo_job(
        &self,
        offscreen: Option<Arc<std::sync::Mutex<crate::offscreen::OffscreenRenderer>>>,
    ) -> Option<PhotoJob> {
        Some(PhotoJob {
            body: self.body.as_ref()?.model.clone(),
            networks: self.networks.as_ref().map(|n| n.models.clone()),
            dwpose: self.dwpose.clone(),
            pipeline: self.pipeline.clone(),
            offscreen,
        })
    }

    /// Takes in what a job loaded from `path`; what is open stays as it is on an error.
    /// `limits`: what the device holds (splat files beyond it are refused); `look_from_photo`:
    /// an avatar made here is then seen through its photo's camera (the first launch's demo).
    pub(crate) fn take(
        &mut self,
        path: &Path,
        loaded: Loaded,
        limits: &wgpu::Limits,
        look_from_photo: bool,
    ) -> Result<Taken, String> {
        match loaded {
            Loaded::Cloud(cloud) => self.take_cloud(path, cloud, limits),
            Loaded::Body(model) => Ok(self.set_body(model, &path.display().to_string())),
            Loaded::Networks(models) => Ok(self.set_networks(*models)),
            Loaded::Wholebody(dir) => {
                let status = format!(
                    "EHM-Tracker's keypoint models: {} (DWPose places the body and hand points \
                     of fitted photos)",
                    dir.display()
                );
                self.dwpose = Some(dir);
                Ok(Taken::status(status))
            }
            Loaded::Motion(imported) => {
                let label = format!("{} — {}", file_name(path), imported.tracking.source);
                self.set_motion(label, imported)
            }
            Loaded::Avatar(loaded) => self.take_avatar(path, *loaded, look_from_photo),
        }
    }

    /// Shows an avatar if it fits the current body (then built with the avatar's identity);
    /// otherwise keeps what is shown.
    fn take_avatar(
        &mut self,
        path: &Path,
        loaded: LoadedAvatar,
        look_from_photo: bool,
    ) -> Result<Taken, String> {
        let LoadedAvatar {
            avatar,
            summary,
            preview,
            source_camera,
            mut fidelity,
        } = loaded;
        let body = self.body.as_mut().ok_or("no body to pose the avatar on")?;
        avatar
            .check_body(&*body.model)
            .map_err(|e| format!("{}: {e}; the current view is kept", path.display()))?;
        body.take_identity(&avatar);
        if let Some(motion) = &mut self.motion {
            motion.resample();
        }
        let mut label = format!("{} — {}", avatar.kind.label(), avatar.source);
        if let Some(summary) = summary {
            label.push_str("; ");
            label.push_str(&summary);
        }
        let status = format!(
            "{}: {} Gaussians ({}), {} channels",
            file_name(path),
            avatar.len(),
            avatar.composition(),
            avatar.channels
        );
        // Made again from the same photo (the fit adjusted): keep how the last one compared.
        if let (Some(Ok(new)), Some(old)) = (&mut fidelity, &self.avatar)
            && old.avatar.source == avatar.source
            && let Some(Ok(before)) = &old.fidelity
        {
            new.before = Some(before.metrics);
        }
        let state = AvatarState::new(avatar, label, preview, source_camera, fidelity);
        crate::recovery::keep(state.avatar.clone());
        self.avatar = Some(state);
        let camera = match look_from_photo && source_camera.is_some() {
            true => CameraMode::Source,
            false => CameraMode::Orbit,
        };
        Ok(Taken {
            camera: Some(camera),
            ..Taken::show(status, View::Avatar, true)
        })
    }

    /// Shows a loaded cloud, unless it is empty or too big for the GPU: then the current scene
    /// stays.
    fn take_cloud(
        &mut self,
        path: &Path,
        cloud: GaussianCloud,
        limits: &wgpu::Limits,
    ) -> Result<Taken, String> {
        let storage = guava::render::FeatureStorage::F32;
        let max = max_gaussians(limits, cloud.channels as u32, storage);
        if cloud.is_empty() {
            return Err(format!("{}: the file has no Gaussians", path.display()));
        }
        if cloud.len() as u64 > max {
            return Err(format!(
                "{}: {} Gaussians with {} channels exceed what this GPU can hold ({max}); the \
                 current scene is kept",
                path.display(),
                cloud.len(),
                cloud.channels
            ));
        }
        Ok(self.set_scene(file_name(path), "splat file", cloud))
    }

    /// Shows `cloud` as the splat scene.
    pub(crate) fn set_scene(
        &mut self,
        name: String,
        kind: &'static str,
        cloud: GaussianCloud,
    ) -> Taken {
        let status = format!(
            "{name}: {} Gaussians, {} channels",
            cloud.len(),
            cloud.channels
        );
        self.scene = Some(Scene {
            name,
            kind,
            cloud: Arc::new(cloud),
            id: next_id(),
        });
        Taken::show(status, View::Gaussians, true)
    }

    /// Plays `imported` on the current body (there always is one: the default at least).
    pub(crate) fn set_motion(
        &mut self,
        label: String,
        imported: Imported,
    ) -> Result<Taken, String> {
        let body = self.body.as_ref().ok_or("no body to play the motion on")?;
        let frames = imported.tracking.frames.len();
        let fps = imported.tracking.fps;
        let motion = Motion::new(label, imported, body.model.as_ref());
        let notes = match motion.notes().len() {
            0 => String::new(),
            n => format!(" ({n} notes in the Motion panel)"),
        };
        let status = format!("{}: {frames} frames at {fps} fps{notes}", motion.label);
        self.motion = Some(motion);
        Ok(Taken::show(status, View::Body, false))
    }

    /// Replaces the posed body (a validated template or EHM) and shows it; an avatar made for
    /// another body is closed.
    pub(crate) fn set_body(&mut self, model: AnyBody, source: &str) -> Taken {
        let what = match &model {
            AnyBody::Template(_) => "body model, not a GUAVA avatar",
            AnyBody::Ehm(_) => "EHM, GUAVA mode's body (SMPL-X with a FLAME head)",
        };
        let label = format!(
            "{source}: {} ({}) — {what}",
            model.name(),
            model.size_label()
        );
        if let Some(motion) = &mut self.motion {
            motion.retarget_to(&model);
        }
        if let Some(avatar) = &self.avatar
            && avatar.avatar.check_body(&model).is_err()
        {
            self.avatar = None;
        }
        self.body = Some(BodyState::new(model, label.clone()));
        Taken::show(label, View::Body, true)
    }

    /// Takes GUAVA's networks (GUAVA mode reconstructs photos with them on an EHM body).
    fn set_networks(&mut self, models: GuavaModels) -> Taken {
        let d = models.dims;
        let label = format!(
            "GUAVA networks: {} (weights: {}; {}² image, {} vertices, {}² UV map, {} channels)",
            models.dir.display(),
            models.source,
            d.image,
            d.vertices,
            d.uv,
            d.colors
        );
        self.networks = Some(Networks {
            dir: models.dir.clone(),
            models: Arc::new(std::sync::Mutex::new(models)),
            label: label.clone(),
        });
        Taken::status(label)
    }

    /// Writes the avatar shown to `path` (atomically: the old file stays if this fails).
    pub(crate) fn save_avatar(&self, path: &Path) -> Result<String, String> {
        let avatar = &self.avatar.as_ref().ok_or("no avatar to save")?.avatar;
        avatar.save(path).map_err(|e| e.to_string())?;
        Ok(format!("saved {}", path.display()))
    }

    /// Writes the splat scene to `path` as a 3DGS PLY.
    pub(crate) fn save_scene(&self, path: &Path) -> Result<String, String> {
        let scene = self.scene.as_ref().ok_or("no splat scene to save")?;
        guava::gaussians::ply::write(path, &scene.cloud).map_err(|e| e.to_string())?;
        Ok(format!("saved {}", path.display()))
    }
}

/// An `.npz` file: an EHM body (its `format` entry says so) or an SMPL-X motion.
fn open_npz(path: &Path) -> Result<Loaded, String> {
    let npz = guava::npz::Npz::open(path).map_err(|e| e.to_string())?;
    if npz.contains("format") {
        EhmModel::from_opened(&npz, path)
            .map(|m| Loaded::Body(AnyBody::Ehm(Box::new(m))))
            .map_err(|e| e.to_string())
    } else {
        guava::tracking::import::smplx_from_npz(&npz)
            .map(Loaded::Motion)
            .map_err(|e| e.to_string())
    }
}
