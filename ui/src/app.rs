//! The viewer window: menu, scene panel with camera and render controls and the HUD, status bar,
//! drag-and-drop, and the viewport. Loading runs on a worker thread with progress and Cancel.

use crate::avatar_view::{AvatarState, FitAction, Preview, SourcePreview, TrackedPhoto};
use crate::body_model::ViewerBody;
use crate::body_panel::BodyState;
use crate::motion::Motion;
use crate::orbit::OrbitCamera;
use crate::viewport::{
    Content, DisplaySettings, SceneRef, ViewportCallback, ViewportReport, ViewportResources,
};
use guava::avatar::{Avatar, AvatarKind};
use guava::body::{BodyModel, EhmModel, Posable};
use guava::camera::Camera;
use guava::gaussians::GaussianCloud;
use guava::guava_mode::GuavaModels;
use guava::render::present::PresentMode;
use guava::render::splatter::max_gaussians;
use guava::tracking::import::{Imported, open_motion};
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Start-up options from the command line.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Files (or GUAVA's networks folder) to open, one after another.
    pub open: Vec<PathBuf>,
    pub test_scene: bool,
    /// Save the window's own frame as PNG when `exit_after_secs` have passed, then close.
    pub screenshot: Option<PathBuf>,
    pub exit_after_secs: Option<f32>,
    /// Start playing the demo motion (the window does; tests start paused at frame 0).
    pub autoplay: bool,
    /// Start paused at this time of the motion (seconds), e.g. for scripted screenshots.
    pub motion_time: Option<f32>,
}

struct Scene {
    name: String,
    /// Where it came from and what it is, shown in the panel (never "GUAVA avatar" unless it is one).
    kind: &'static str,
    cloud: Arc<GaussianCloud>,
    generation: u64,
}

/// What the viewport shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// The posed body template as a mesh.
    Body,
    /// The loaded Gaussian scene through the splatting pass.
    Gaussians,
    /// The avatar's Gaussians on the posed body, through the splatting pass.
    Avatar,
}

/// Where the viewport looks from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraMode {
    /// The orbit camera (mouse and sliders).
    Orbit,
    /// The camera of the photo the avatar was reconstructed from.
    Source,
    /// The motion's tracked camera at the current time.
    Tracked,
}

/// What a worker thread loaded.
enum Loaded {
    Cloud(GaussianCloud),
    Body(ViewerBody),
    Motion(Imported),
    /// GUAVA's exported networks (GUAVA mode).
    Networks(Box<GuavaModels>),
    /// EHM-Tracker's keypoint models folder, checked by loading it.
    Wholebody(PathBuf),
    /// An avatar file, or a reconstruction (then with a summary of what it saw, what the panel
    /// shows of the photo, and the photo's camera).
    Avatar(
        Box<Avatar>,
        Option<String>,
        Preview,
        Option<(glam::Mat4, f32)>,
    ),
}

/// GUAVA mode's networks, shared with reconstruction workers (a session runs one call at a time).
struct Networks {
    models: Arc<Mutex<GuavaModels>>,
    /// The folder and where its weights came from, shown in the panel.
    label: String,
}

struct Loading {
    path: PathBuf,
    started: Instant,
    rx: Receiver<Result<Loaded, String>>,
    /// The stage a long job is in, shown beside the spinner.
    stage: Arc<Mutex<&'static str>>,
    /// Set by Cancel; jobs that check it stop at their next stage.
    cancel: Arc<AtomicBool>,
}

pub struct GuavaApp {
    options: Options,
    scene: Option<Scene>,
    body: Option<BodyState>,
    avatar: Option<AvatarState>,
    /// The motion driving the body (the demo motion until another is opened).
    motion: Option<Motion>,
    /// GUAVA's networks, once the user opened their folder (GUAVA mode with an EHM body).
    networks: Option<Networks>,
    /// EHM-Tracker's keypoint models folder, once the user opened it: its DWPose places the body
    /// and hand points when photos are fitted.
    dwpose: Option<PathBuf>,
    /// The keypoint models photo jobs use, kept between jobs.
    keypoint_models: Arc<Mutex<KeypointModels>>,
    view: View,
    next_generation: u64,
    orbit: OrbitCamera,
    camera_mode: CameraMode,
    display: DisplaySettings,
    background: [f32; 3],
    report: Arc<Mutex<ViewportReport>>,
    loading: Option<Loading>,
    /// Files waiting to open once the current load is done (several dropped at once).
    queue: VecDeque<PathBuf>,
    status: Option<(String, bool)>,
    frames: u64,
    /// When the window was created (for `exit_after_secs`).
    launched: Instant,
    exiting: bool,
    gpu_ready: bool,
    adapter: String,
    limits: wgpu::Limits,
    last_frame: Option<Instant>,
    frame_ms: f32,
}

impl GuavaApp {
    pub fn new(cc: &eframe::CreationContext<'_>, options: Options) -> Self {
        let (gpu_ready, adapter, limits) = match cc.wgpu_render_state.as_ref() {
            Some(rs) => {
                let resources =
                    ViewportResources::new(&rs.device, &rs.adapter.get_info(), rs.target_format);
                rs.renderer.write().callback_resources.insert(resources);
                (
                    true,
                    guava::gpu::adapter_label(&rs.adapter.get_info()),
                    rs.device.limits(),
                )
            }
            None => (false, "no wgpu device".into(), wgpu::Limits::default()),
        };
        let mut app = Self {
            options: options.clone(),
            scene: None,
            body: None,
            avatar: None,
            motion: None,
            networks: None,
            dwpose: None,
            keypoint_models: Arc::default(),
            view: View::Body,
            next_generation: 0,
            orbit: OrbitCamera::default(),
            camera_mode: CameraMode::Orbit,
            display: DisplaySettings::default(),
            background: [0.0; 3],
            report: Arc::default(),
            loading: None,
            queue: VecDeque::new(),
            status: None,
            frames: 0,
            launched: Instant::now(),
            exiting: false,
            gpu_ready,
            adapter,
            limits,
            last_frame: None,
            frame_ms: 0.0,
        };
        app.load_default_body();
        app.load_demo_motion();
        if options.test_scene {
            app.open_test_scene();
        }
        app.queue = options.open.iter().cloned().collect();
        app
    }

    /// Shows the embedded default body (Anny).
    fn load_default_body(&mut self) {
        match BodyModel::default_body() {
            Ok(model) => self.set_body(
                ViewerBody::Template(Arc::new(model)),
                "default body template",
            ),
            Err(e) => self.error(e.to_string()),
        }
    }

    /// Puts the demo motion on the timeline.
    fn load_demo_motion(&mut self) {
        match guava::tracking::demo_motion() {
            Ok(tracking) => {
                let imported = Imported {
                    tracking,
                    notes: Vec::new(),
                };
                self.set_motion(
                    "demo motion — authored keyframes (tools/make_demo_motion.py), not tracked from a video".into(),
                    imported,
                );
                if let Some(motion) = &mut self.motion {
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
        let Some(body) = &self.body else {
            return self.error("no body to play the motion on".into());
        };
        let frames = imported.tracking.frames.len();
        let fps = imported.tracking.fps;
        let motion = Motion::new(label, imported, body.model.as_ref());
        let notes = motion.notes().len();
        self.status = Some((
            format!(
                "{}: {frames} frames at {fps} fps{}",
                motion.label,
                if notes > 0 {
                    format!(" ({notes} notes in the Motion panel)")
                } else {
                    String::new()
                }
            ),
            false,
        ));
        self.motion = Some(motion);
        self.view = View::Body;
    }

    pub fn motion(&self) -> Option<&Motion> {
        self.motion.as_ref()
    }

    pub fn motion_mut(&mut self) -> Option<&mut Motion> {
        self.motion.as_mut()
    }

    /// Replaces the posed body (a validated template or EHM) and shows it.
    fn set_body(&mut self, model: ViewerBody, source: &str) {
        self.next_generation += 1;
        let what = match &model {
            ViewerBody::Template(_) => "body model, not a GUAVA avatar",
            ViewerBody::Ehm(_) => "EHM, GUAVA mode's body (SMPL-X with a FLAME head)",
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
        self.body = Some(BodyState::new(model, label, self.next_generation));
        self.view = View::Body;
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
        self.status = Some((label.clone(), false));
        self.networks = Some(Networks {
            models: Arc::new(Mutex::new(models)),
            label,
        });
    }

    /// Which reconstruction a dropped photo gets, and the files GUAVA mode needs.
    fn mode_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Mode");
        let ehm = self.body.as_ref().is_some_and(|b| b.model.is_ehm());
        ui.label(match (ehm, &self.networks) {
            (false, _) => {
                "Default mode: photos become the default reconstruction on a body template (no \
                 learned weights). GUAVA mode needs an EHM body and GUAVA's networks."
            }
            (true, None) => {
                "GUAVA mode: EHM body open; open GUAVA's networks folder to reconstruct photos."
            }
            (true, Some(_)) => {
                "GUAVA mode: photos are reconstructed by GUAVA's networks on the EHM body, with \
                 their tracking (.json beside them) or fitted to their keypoints."
            }
        });
        if let Some(n) = &self.networks {
            ui.label(&n.label);
        }
        ui.label(match &self.dwpose {
            Some(dir) => format!(
                "Keypoints: body and hands from EHM-Tracker's DWPose ({}); face, irises and mask \
                 from MediaPipe's models",
                dir.display()
            ),
            None => "Keypoints: MediaPipe's models (shipped)".into(),
        });
        let mut pick = None;
        ui.horizontal(|ui| {
            if ui
                .button("EHM body…")
                .on_hover_text("an EHM body converted by tools/convert_ehm.py (.npz)")
                .clicked()
            {
                pick = rfd::FileDialog::new()
                    .add_filter("EHM body", &["npz"])
                    .pick_file();
            }
            if ui
                .button("Networks folder…")
                .on_hover_text("GUAVA's networks exported by tools/export_guava_onnx.py")
                .clicked()
            {
                pick = rfd::FileDialog::new().pick_folder();
            }
            if ehm && ui.button("Default body").clicked() {
                self.load_default_body();
            }
        });
        ui.horizontal(|ui| {
            if ui
                .button("EHM-Tracker's keypoint models…")
                .on_hover_text(
                    "EHM-Tracker's checkpoint folder with yolox_l.onnx and dw-ll_ucoco_384.onnx",
                )
                .clicked()
                && let Some(dir) = rfd::FileDialog::new().pick_folder()
            {
                self.open_wholebody(dir);
            }
            if self.dwpose.is_some() && ui.button("MediaPipe's keypoints").clicked() {
                self.dwpose = None;
            }
        });
        if let Some(path) = pick {
            self.open(path);
        }
    }

    pub fn view(&self) -> View {
        self.view
    }

    /// Switches the viewport and frames what it now shows.
    pub fn set_view(&mut self, view: View) {
        if self.view != view {
            self.view = view;
            self.reset_camera();
        }
    }

    fn view_choice_ui(&mut self, ui: &mut egui::Ui) {
        let mut view = self.view;
        ui.selectable_value(&mut view, View::Body, "Body mesh");
        ui.selectable_value(&mut view, View::Gaussians, "Gaussians");
        if self.avatar.is_some() {
            ui.selectable_value(&mut view, View::Avatar, "Avatar");
        }
        self.set_view(view);
    }

    /// The body panel's description of the current body (its source and model name).
    pub fn body_label(&self) -> Option<&str> {
        self.body.as_ref().map(|b| b.label.as_str())
    }

    pub fn body_mut(&mut self) -> Option<&mut BodyState> {
        self.body.as_mut()
    }

    /// The avatar panel's description (its kind and source) and its Gaussian count.
    pub fn avatar_info(&self) -> Option<(&str, usize)> {
        self.avatar
            .as_ref()
            .map(|a| (a.label.as_str(), a.avatar.len()))
    }

    pub fn scene_len(&self) -> Option<usize> {
        self.scene.as_ref().map(|s| s.cloud.len())
    }

    pub fn status(&self) -> Option<&str> {
        self.status.as_ref().map(|(s, _)| s.as_str())
    }

    pub fn camera_mode(&self) -> CameraMode {
        self.camera_mode
    }

    /// Looks through the orbit, the source photo's or the motion's tracked camera (the panel's
    /// choice); a camera the current content lacks falls back to the orbit.
    pub fn set_camera_mode(&mut self, mode: CameraMode) {
        self.camera_mode = mode;
    }

    /// Turns the orbit camera (what dragging or the yaw slider does).
    pub fn set_yaw_deg(&mut self, yaw: f32) {
        self.orbit.yaw_rad = yaw.to_radians();
    }

    pub fn report(&self) -> ViewportReport {
        self.report.lock().map(|r| r.clone()).unwrap_or_default()
    }

    fn set_scene(&mut self, name: String, kind: &'static str, cloud: GaussianCloud) {
        self.next_generation += 1;
        self.orbit = OrbitCamera::framing(&cloud, self.orbit.fov_y_rad);
        let channels = cloud.channels as u32;
        self.display.rgb_channels = self.display.rgb_channels.map(|c| c.min(channels - 1));
        self.status = Some((
            format!(
                "{name}: {} Gaussians, {} channels",
                cloud.len(),
                cloud.channels
            ),
            false,
        ));
        self.scene = Some(Scene {
            name,
            kind,
            cloud: Arc::new(cloud),
            generation: self.next_generation,
        });
        self.view = View::Gaussians;
    }

    pub fn open_test_scene(&mut self) {
        let cloud = guava::gaussians::synthetic::torus_knot(40_000, 1);
        self.set_scene(
            "test scene".into(),
            "synthetic test scene (not an avatar)",
            cloud,
        );
    }

    /// Starts loading a file (or GUAVA's networks folder) on a worker thread; the current scene
    /// stays until it succeeds.
    pub fn open(&mut self, path: PathBuf) {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        enum Kind {
            Cloud,
            Body,
            /// An EHM body (GUAVA mode) or an SMPL-X motion: told apart by the file's contents.
            Npz,
            Networks,
            Motion,
            Avatar,
            Photo(Option<PathBuf>, PhotoJob),
        }
        use guava::reconstruct::Tracked;
        let kind = match ext.as_deref() {
            _ if path.is_dir()
                && guava::keypoints::WHOLEBODY_FILES
                    .iter()
                    .all(|f| path.join(f).is_file()) =>
            {
                return self.open_wholebody(path);
            }
            _ if path.is_dir() => Kind::Networks,
            Some("ply" | "splat") => Kind::Cloud,
            Some("glb") => Kind::Body,
            Some("npz") => Kind::Npz,
            Some("json" | "csv") => Kind::Motion,
            Some("guava") => Kind::Avatar,
            Some("png" | "jpg" | "jpeg") => {
                // Its tracking file beside it, if there is one; otherwise the pose is fitted.
                let tracking = guava::reconstruct::tracking_beside(&path);
                let Some(job) = self.photo_job() else {
                    return self.error("no body to reconstruct on".into());
                };
                Kind::Photo(tracking.is_file().then_some(tracking), job)
            }
            _ => {
                self.error(format!(
                    "{}: unsupported file type (open a 3DGS .ply, a body template .glb, an EHM \
                     body .npz, GUAVA's networks folder, an avatar .guava, a photo .png/.jpg with \
                     its tracking .json, or a motion: tracking .json, ARKit .csv, SMPL-X .npz)",
                    path.display()
                ));
                return;
            }
        };
        let worker_path = path.clone();
        self.spawn_job(
            path,
            "reading",
            move |worker_stage, worker_cancel| match kind {
                Kind::Avatar => Avatar::load(&worker_path)
                    .map(|a| Loaded::Avatar(Box::new(a), None, Preview::None, None))
                    .map_err(|e| e.to_string()),
                Kind::Photo(tracking, job) => job.run(
                    &worker_path,
                    tracking.as_deref().map_or(Tracked::Fit, Tracked::File),
                    worker_stage,
                    worker_cancel,
                ),
                Kind::Body => BodyModel::load(&worker_path)
                    .map(|m| Loaded::Body(ViewerBody::Template(Arc::new(m))))
                    .map_err(|e| e.to_string()),
                Kind::Npz => open_npz(&worker_path),
                Kind::Networks => {
                    *worker_stage.lock().unwrap_or_else(|e| e.into_inner()) =
                        "loading GUAVA's networks";
                    guava::onnx::OnnxRuntime::load()
                        .map_err(|e| e.to_string())
                        .and_then(|rt| {
                            GuavaModels::load_dir(rt, &worker_path).map_err(|e| e.to_string())
                        })
                        .map(|m| Loaded::Networks(Box::new(m)))
                }
                Kind::Cloud => guava::gaussians::read_file(&worker_path)
                    .map(Loaded::Cloud)
                    .map_err(|e| e.to_string()),
                Kind::Motion => open_motion(&worker_path)
                    .map(Loaded::Motion)
                    .map_err(|e| e.to_string()),
            },
        );
    }

    /// Loads EHM-Tracker's keypoint models folder on a worker thread into the models photo jobs
    /// use (so the next photo does not load them again); once it loads, photos are fitted with
    /// its body and hand points.
    fn open_wholebody(&mut self, dir: PathBuf) {
        let (worker_dir, models) = (dir.clone(), self.keypoint_models.clone());
        self.spawn_job(
            dir,
            "loading EHM-Tracker's keypoint models",
            move |stage, _| {
                let mut models = models.lock().unwrap_or_else(|e| e.into_inner());
                models.wanted = Some(worker_dir.clone());
                models.ensure(stage)?;
                Ok(Loaded::Wholebody(worker_dir))
            },
        );
    }

    /// What a photo's reconstruction needs from the app (`None` without a body).
    fn photo_job(&self) -> Option<PhotoJob> {
        Some(PhotoJob {
            body: self.body.as_ref()?.model.clone(),
            networks: self.networks.as_ref().map(|n| n.models.clone()),
            dwpose: self.dwpose.clone(),
            keypoint_models: self.keypoint_models.clone(),
        })
    }

    /// Runs `job` on a worker thread, showing its stage with a Cancel button; what it loads is
    /// taken in by [`Self::poll_loading`].
    fn spawn_job(
        &mut self,
        path: PathBuf,
        first_stage: &'static str,
        job: impl FnOnce(&Mutex<&'static str>, &AtomicBool) -> Result<Loaded, String> + Send + 'static,
    ) {
        let (tx, rx) = std::sync::mpsc::channel();
        let stage = Arc::new(Mutex::new(first_stage));
        let cancel = Arc::new(AtomicBool::new(false));
        let (worker_stage, worker_cancel) = (stage.clone(), cancel.clone());
        std::thread::spawn(move || {
            // The receiver is gone if the user cancelled: nothing to do then.
            let _ = tx.send(job(&worker_stage, &worker_cancel));
        });
        self.loading = Some(Loading {
            path,
            started: Instant::now(),
            rx,
            stage,
            cancel,
        });
    }

    /// Reconstructs the avatar's source photo again with `view` (the fit adjusted by hand).
    pub fn reconstruct_with_pose(&mut self, photo: PathBuf, view: guava::reconstruct::SourceView) {
        let Some(job) = self.photo_job() else {
            return self.error("no body to reconstruct on".into());
        };
        let worker_photo = photo.clone();
        self.spawn_job(photo, "reading", move |stage, cancel| {
            let given = guava::reconstruct::Tracked::Given(view);
            job.run(&worker_photo, given, stage, cancel)
        });
    }

    /// The current body when it is a template (what the default reconstruction and the fit work
    /// on); otherwise says so and gives `None`.
    fn template_body(&mut self) -> Option<Arc<BodyModel>> {
        match self.body.as_ref().map(|b| &*b.model) {
            Some(ViewerBody::Template(m)) => Some(m.clone()),
            Some(ViewerBody::Ehm(_)) => {
                self.error(
                    "the default reconstruction works on a body template; the current body is \
                     EHM (GUAVA mode): Mode > Default body first"
                        .into(),
                );
                None
            }
            None => {
                self.error("no body to reconstruct on".into());
                None
            }
        }
    }

    /// Reconstructs a synthetic photo of the current body (the known-answer demo: the body with a
    /// colour pattern, drawn from GUAVA's camera), so a fresh install can make an avatar offline.
    pub fn reconstruct_synthetic_photo(&mut self) {
        use guava::reconstruct::{SourceView, synthetic};
        let Some(model) = self.template_body() else {
            return;
        };
        let view = SourceView {
            pose: guava::body::BodyPose::rest(model.as_ref()),
            camera: synthetic::upper_body_camera(&model, 0.35),
            crop: None,
        };
        self.spawn_job(
            SYNTHETIC_PHOTO.into(),
            "drawing the synthetic photo",
            move |stage, cancel| {
                let image =
                    synthetic::photo(&model, &view.pose, &view.camera, synthetic::banded_texture)
                        .map_err(|e| e.to_string())?;
                let source =
                    guava::reconstruct::SourceImage::from_rgba(&image, true, SYNTHETIC_PHOTO)
                        .map_err(|e| e.to_string())?;
                let uv = guava::reconstruct::UvMap::for_body(
                    &model,
                    guava::reconstruct::DEFAULT_UV_SIZE,
                );
                guava::reconstruct::reconstruct_default(
                    &model,
                    &uv,
                    &view,
                    source,
                    SYNTHETIC_PHOTO,
                    &mut progress(stage, cancel),
                )
                .map(|(a, r)| {
                    let camera = (view.camera.view_from_world, view.camera.invtanfov());
                    let summary = Some(default_summary(&r, None, None));
                    Loaded::Avatar(Box::new(a), summary, Preview::None, Some(camera))
                })
                .map_err(|e| e.to_string())
            },
        );
    }

    /// Shows an avatar if it fits the current body (then built with the avatar's identity);
    /// otherwise keeps what is shown.
    fn accept_avatar(
        &mut self,
        path: &Path,
        avatar: Avatar,
        summary: Option<String>,
        preview: Preview,
        source_camera: Option<(glam::Mat4, f32)>,
    ) {
        let Some(body) = &mut self.body else {
            return self.error("no body to pose the avatar on".into());
        };
        if let Err(e) = avatar.check_body(&*body.model) {
            return self.error(format!("{}: {e}; the current view is kept", path.display()));
        }
        body.take_identity(&avatar);
        let mut label = format!("{} — {}", avatar.kind.label(), avatar.source);
        if let Some(summary) = summary {
            label.push_str("; ");
            label.push_str(&summary);
        }
        self.status = Some((
            format!(
                "{}: {} Gaussians ({} template + {} UV), {} channels",
                file_name(path),
                avatar.len(),
                avatar.template.len(),
                avatar.uv.local.len(),
                avatar.channels
            ),
            false,
        ));
        self.avatar = Some(AvatarState::new(avatar, label, preview, source_camera));
        self.camera_mode = CameraMode::Orbit;
        self.view = View::Avatar;
        self.reset_camera();
    }

    /// Whether the body sliders are posing the source photo's body (the fit edited by hand).
    pub fn editing_fit(&self) -> bool {
        self.avatar
            .as_ref()
            .and_then(|a| a.source.as_ref())
            .is_some_and(SourcePreview::editing)
    }

    /// Adjusting the source photo's fit by hand: start (the body takes the fit's pose, playback
    /// pauses, the view looks through the photo's camera), stop, reconstruct with the body's
    /// current pose, or save it as a tracking file.
    pub fn fit_action(&mut self, action: FitAction) {
        let (Some(avatar), Some(body)) = (&mut self.avatar, &mut self.body) else {
            return;
        };
        let Some(source) = &mut avatar.source else {
            return;
        };
        let view = guava::reconstruct::SourceView {
            pose: body.pose.clone(),
            camera: source.view.camera,
            crop: source.view.crop,
        };
        match action {
            FitAction::StartEditing => {
                source.set_editing(true, body);
                if let Some(motion) = &mut self.motion {
                    motion.player.playing = false;
                }
                self.camera_mode = CameraMode::Source;
            }
            FitAction::StopEditing => source.set_editing(false, body),
            FitAction::Reconstruct => {
                let photo = source.photo.clone();
                self.reconstruct_with_pose(photo, view);
            }
            FitAction::SaveTracking => {
                let photo = source.photo.clone();
                let name = file_name(&photo);
                let tracking = view.to_tracking(
                    &*body.model,
                    &format!(
                        "fitted in guava-viewer to {name}, adjusted by hand; {}",
                        body.model.name()
                    ),
                );
                let Some(path) = rfd::FileDialog::new()
                    .add_filter("tracking", &["json"])
                    .set_file_name(
                        guava::reconstruct::tracking_beside(Path::new(&name))
                            .display()
                            .to_string(),
                    )
                    .save_file()
                else {
                    return;
                };
                match tracking.save(&path) {
                    Ok(()) => {
                        self.status = Some((format!("saved the fit as {}", path.display()), false))
                    }
                    Err(e) => self.error(format!("{}: {e}", path.display())),
                }
            }
        }
    }

    fn save_avatar_dialog(&mut self) {
        let Some(state) = &self.avatar else { return };
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
        match state.avatar.save(&path) {
            Ok(()) => self.status = Some((format!("saved {}", path.display()), false)),
            Err(e) => self.error(e.to_string()),
        }
    }

    fn error(&mut self, message: String) {
        log::warn!("{message}");
        self.status = Some((message, true));
    }

    fn poll_loading(&mut self) {
        let Some(loading) = &self.loading else { return };
        match loading.rx.try_recv() {
            Err(TryRecvError::Empty) => {}
            Err(TryRecvError::Disconnected) => {
                let path = loading.path.display().to_string();
                self.loading = None;
                self.error(format!("{path}: loading stopped unexpectedly"));
            }
            Ok(result) => {
                let path = loading.path.clone();
                self.loading = None;
                match result {
                    Ok(Loaded::Cloud(cloud)) => self.accept_loaded(&path, cloud),
                    Ok(Loaded::Body(model)) => self.set_body(model, &path.display().to_string()),
                    Ok(Loaded::Networks(models)) => self.set_networks(*models),
                    Ok(Loaded::Wholebody(dir)) => {
                        self.status = Some((
                            format!(
                                "EHM-Tracker's keypoint models: {} (DWPose places the body and \
                                 hand points of fitted photos)",
                                dir.display()
                            ),
                            false,
                        ));
                        self.dwpose = Some(dir);
                    }
                    Ok(Loaded::Motion(imported)) => {
                        let label = format!("{} — {}", file_name(&path), imported.tracking.source);
                        self.set_motion(label, imported);
                    }
                    Ok(Loaded::Avatar(avatar, summary, preview, camera)) => {
                        self.accept_avatar(&path, *avatar, summary, preview, camera)
                    }
                    Err(e) => self.error(e),
                }
            }
        }
    }

    /// Shows a loaded cloud, unless it is empty or too big for the GPU: then the current scene stays.
    fn accept_loaded(&mut self, path: &Path, cloud: GaussianCloud) {
        let max = max_gaussians(&self.limits, cloud.channels as u32);
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

    fn save_ply_dialog(&mut self) {
        let Some(scene) = &self.scene else { return };
        let Some(path) = rfd::FileDialog::new()
            .add_filter("3DGS PLY", &["ply"])
            .set_file_name(format!("{}.ply", scene.name))
            .save_file()
        else {
            return;
        };
        match guava::gaussians::ply::write(&path, &scene.cloud) {
            Ok(()) => self.status = Some((format!("saved {}", path.display()), false)),
            Err(e) => self.error(e.to_string()),
        }
    }

    fn menu_ui(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open…").clicked() {
                    if let Some(path) = rfd::FileDialog::new()
                        .add_filter(
                            "Splats (PLY, .splat), body template, avatar, photo or motion",
                            &[
                                "ply", "splat", "glb", "guava", "png", "jpg", "jpeg", "json",
                                "csv", "npz",
                            ],
                        )
                        .pick_file()
                    {
                        self.open(path);
                    }
                    ui.close();
                }
                if ui.button("Open GUAVA networks folder…").clicked() {
                    if let Some(dir) = rfd::FileDialog::new().pick_folder() {
                        self.open(dir);
                    }
                    ui.close();
                }
                if ui.button("Open test scene").clicked() {
                    self.open_test_scene();
                    ui.close();
                }
                if ui.button("Reconstruct demo portrait").clicked() {
                    self.open(demo_portrait());
                    ui.close();
                }
                if ui.button("Reconstruct synthetic photo").clicked() {
                    self.reconstruct_synthetic_photo();
                    ui.close();
                }
                if ui
                    .add_enabled(self.scene.is_some(), egui::Button::new("Save PLY as…"))
                    .clicked()
                {
                    self.save_ply_dialog();
                    ui.close();
                }
                if ui
                    .add_enabled(self.avatar.is_some(), egui::Button::new("Save avatar as…"))
                    .clicked()
                {
                    self.save_avatar_dialog();
                    ui.close();
                }
                ui.separator();
                if ui.button("Quit").clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("View", |ui| {
                self.view_choice_ui(ui);
                ui.separator();
                if ui.button("Reset camera").clicked() {
                    self.reset_camera();
                    ui.close();
                }
            });
        });
    }

    fn reset_camera(&mut self) {
        let fov = self.orbit.fov_y_rad;
        match self.view {
            View::Gaussians => {
                if let Some(scene) = &self.scene {
                    self.orbit = OrbitCamera::framing(&scene.cloud, fov);
                }
            }
            View::Body | View::Avatar => {
                if let Some(body) = &mut self.body {
                    let (lo, hi) = body.bounds();
                    self.orbit = OrbitCamera {
                        y_up: true,
                        ..OrbitCamera::framing_box(lo, hi, fov)
                    };
                }
            }
        }
    }

    fn side_panel_ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.label("View");
            self.view_choice_ui(ui);
        });
        ui.separator();
        if let (View::Avatar, Some(avatar)) = (self.view, &mut self.avatar) {
            ui.heading("Avatar");
            ui.label(&avatar.label);
            let a = &avatar.avatar;
            ui.label(format!(
                "{} Gaussians: {} template + {} UV · {} channels ({})",
                a.len(),
                a.template.len(),
                a.uv.local.len(),
                a.channels,
                match a.kind {
                    AvatarKind::DefaultReconstruction => "RGB, source confidence",
                    AvatarKind::Guava => "RGB, then GUAVA's latent features for its refiner",
                }
            ));
            let mut action = None;
            if let (Some(source), Some(body)) = (&mut avatar.source, &mut self.body) {
                egui::CollapsingHeader::new("Source photo and fit")
                    .default_open(true)
                    .show(ui, |ui| action = source.ui(ui, body));
            }
            if let Some(photo) = &mut avatar.tracked_photo {
                egui::CollapsingHeader::new("Source photo and tracking")
                    .default_open(true)
                    .show(ui, |ui| photo.ui(ui));
            }
            ui.separator();
            if let Some(action) = action {
                self.fit_action(action);
            }
        }
        if matches!(self.view, View::Body | View::Avatar) {
            self.mode_ui(ui);
            ui.separator();
            ui.heading("Body");
            match &mut self.body {
                Some(body) => body.ui(ui),
                None => {
                    ui.label("no body model loaded");
                }
            }
            ui.separator();
            ui.heading("Motion");
            match &self.motion {
                Some(motion) => {
                    motion.info_ui(ui);
                    if ui.button("Unload motion").clicked() {
                        self.motion = None;
                    }
                }
                None => {
                    ui.label("none: open a tracking .json, ARKit .csv or SMPL-X .npz");
                }
            }
            ui.separator();
        }
        ui.heading("Scene");
        match &self.scene {
            Some(s) => {
                ui.label(format!("{} — {}", s.name, s.kind));
                ui.label(format!(
                    "{} Gaussians · {} channels",
                    s.cloud.len(),
                    s.cloud.channels
                ));
            }
            None => {
                ui.label("nothing loaded");
            }
        }
        ui.separator();
        ui.heading("Camera");
        let source = self.avatar.as_ref().and_then(|a| a.source_camera).is_some()
            && self.view == View::Avatar;
        let tracked =
            self.motion.as_ref().and_then(|m| m.camera()).is_some() && self.view != View::Gaussians;
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.camera_mode, CameraMode::Orbit, "orbit");
            ui.add_enabled_ui(source, |ui| {
                ui.selectable_value(&mut self.camera_mode, CameraMode::Source, "source photo")
                    .on_hover_text("the camera of the photo the avatar was reconstructed from");
            });
            ui.add_enabled_ui(tracked, |ui| {
                ui.selectable_value(&mut self.camera_mode, CameraMode::Tracked, "tracked")
                    .on_hover_text("the motion's tracked camera, following the timeline");
            });
        });
        let o = &mut self.orbit;
        let mut yaw = o.yaw_rad.to_degrees();
        let mut pitch = o.pitch_rad.to_degrees();
        let mut fov = o.fov_y_rad.to_degrees();
        let mut moved = ui
            .add(egui::Slider::new(&mut yaw, -180.0..=180.0).text("yaw °"))
            .changed();
        moved |= ui
            .add(egui::Slider::new(&mut pitch, -88.0..=88.0).text("pitch °"))
            .changed();
        moved |= ui
            .add(egui::Slider::new(&mut fov, 5.0..=120.0).text("fov y °"))
            .changed();
        moved |= ui
            .add(
                egui::Slider::new(&mut o.distance, 0.01..=100.0)
                    .logarithmic(true)
                    .text("distance"),
            )
            .changed();
        o.yaw_rad = yaw.to_radians();
        o.pitch_rad = pitch.to_radians();
        o.fov_y_rad = fov.to_radians();
        if ui.button("Reset camera").clicked() {
            moved = true;
            self.reset_camera();
        }
        if moved {
            self.camera_mode = CameraMode::Orbit;
        }
        ui.separator();
        ui.heading("Display");
        let channels = self.scene.as_ref().map_or(3, |s| s.cloud.channels as u32);
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.display.mode, PresentMode::Rgb, "Features");
            ui.selectable_value(&mut self.display.mode, PresentMode::Alpha, "Alpha");
            ui.selectable_value(&mut self.display.mode, PresentMode::InverseDepth, "1/depth");
        });
        if self.display.mode == PresentMode::Rgb && channels > 3 {
            ui.horizontal(|ui| {
                ui.label("channels as RGB");
                for c in &mut self.display.rgb_channels {
                    ui.add(egui::DragValue::new(c).range(0..=channels - 1));
                }
            });
        }
        if self.display.mode == PresentMode::InverseDepth {
            let r = &mut self.display.inv_depth_range;
            ui.add(
                egui::Slider::new(&mut r[1], 0.01..=10.0)
                    .logarithmic(true)
                    .text("1/depth max"),
            );
        }
        ui.horizontal(|ui| {
            ui.label("background");
            ui.color_edit_button_rgb(&mut self.background);
        });
        ui.separator();
        self.hud_ui(ui);
    }

    fn hud_ui(&self, ui: &mut egui::Ui) {
        ui.heading("Frame");
        let report = self.report();
        egui::Grid::new("hud")
            .num_columns(2)
            .min_col_width(120.0)
            .show(ui, |ui| {
                let mut row = |k: &str, v: String| {
                    ui.label(k);
                    ui.monospace(v);
                    ui.end_row();
                };
                row("adapter", self.adapter.clone());
                row("UI frame", format!("{:.1} ms", self.frame_ms));
                row("splat renders", report.renders.to_string());
                if let Some(s) = report.stats {
                    row("drawn", s.visible.to_string());
                    row("culled: near", s.near.to_string());
                    row("culled: off-screen", s.outside.to_string());
                    row("culled: transparent", s.transparent.to_string());
                    row("dropped: NaN/Inf", s.nonfinite.to_string());
                    row("degenerate", s.degenerate.to_string());
                    row("tile pairs", s.tile_pairs.to_string());
                }
            });
    }

    fn viewport_ui(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        let showing = match self.view {
            View::Gaussians => self.scene.is_some(),
            View::Body => self.body.is_some(),
            View::Avatar => self.avatar.is_some() && self.body.is_some(),
        };
        if !showing {
            self.empty_state_ui(ui, rect);
            return;
        }
        if !self.gpu_ready {
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "No wgpu device: the viewer needs a Vulkan, Metal or DX12 adapter.",
                egui::FontId::proportional(16.0),
                ui.visuals().error_fg_color,
            );
            return;
        }
        if response.double_clicked() {
            self.camera_mode = CameraMode::Orbit;
            self.reset_camera();
        } else if self.orbit.handle(&response, ui) {
            // Dragging or zooming takes the view back to the orbit camera.
            self.camera_mode = CameraMode::Orbit;
        }
        let ppp = ui.ctx().pixels_per_point();
        let (w, h) = (
            (rect.width() * ppp).round() as u32,
            (rect.height() * ppp).round() as u32,
        );
        if w == 0 || h == 0 {
            return;
        }
        let splats = |scene: SceneRef| {
            let mut background = vec![0.0; scene.cloud.channels];
            for (c, v) in background.iter_mut().zip(self.background) {
                *c = v;
            }
            Content::Splats {
                scene,
                background,
                display: self.display.clone(),
            }
        };
        let content = match (self.view, &self.scene, &mut self.body) {
            (View::Gaussians, Some(scene), _) => splats(SceneRef {
                generation: scene.generation,
                cloud: scene.cloud.clone(),
            }),
            (View::Avatar, _, Some(body)) => {
                let Some(avatar) = &mut self.avatar else {
                    return;
                };
                match avatar.scene(body, &mut self.next_generation) {
                    Some(scene) => splats(scene),
                    None => return,
                }
            }
            (View::Body, _, Some(body)) => match body.frame(self.background) {
                Some(frame) => Content::Body(frame),
                None => return,
            },
            _ => return,
        };
        let fixed = match self.camera_mode {
            CameraMode::Orbit => None,
            CameraMode::Source => self.avatar.as_ref().and_then(|a| a.source_camera),
            CameraMode::Tracked => self.motion.as_ref().and_then(|m| m.camera()),
        };
        let camera = match fixed {
            Some((w2c, invtanfov)) => Camera::guava_in_viewport(w2c, invtanfov, w, h),
            None => self.orbit.camera(w, h),
        };
        let callback = ViewportCallback {
            content,
            camera,
            report: self.report.clone(),
        };
        ui.painter()
            .add(egui_wgpu::Callback::new_paint_callback(rect, callback));
    }

    fn empty_state_ui(&mut self, ui: &mut egui::Ui, rect: egui::Rect) {
        let mut child = ui.new_child(
            egui::UiBuilder::new()
                .max_rect(rect)
                .layout(egui::Layout::top_down(egui::Align::Center)),
        );
        child.add_space(rect.height() * 0.35);
        child.heading("Nothing loaded");
        child.label("Drop a 3DGS .ply file here, or use File > Open…");
        child.label("(Body templates, .glb, open in the Body mesh view.)");
        child
            .label("(A photo .png/.jpg reconstructs an avatar: with its tracking .json beside it, or fitted.)");
        child.add_space(8.0);
        if child.button("Open test scene").clicked() {
            self.open_test_scene();
        }
        if child.button("Reconstruct demo portrait").clicked() {
            self.open(demo_portrait());
        }
        if child.button("Reconstruct synthetic photo").clicked() {
            self.reconstruct_synthetic_photo();
        }
    }

    fn open_dropped_and_queued(&mut self, ctx: &egui::Context) {
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .collect()
        });
        self.queue.extend(dropped);
        // One load at a time: the next queued file opens when the last one is taken in.
        if self.loading.is_none()
            && let Some(path) = self.queue.pop_front()
        {
            self.open(path);
        }
    }

    fn automation(&mut self, ctx: &egui::Context) {
        self.frames += 1;
        if self.frames == 3 {
            // The real-window test waits for this line before taking its own screenshot.
            println!("guava-viewer: ready");
        }
        let Some(secs) = self.options.exit_after_secs else {
            return;
        };
        ctx.request_repaint();
        // Wall-clock, not frames: a fast GPU would otherwise close before a test can look at it.
        if !self.exiting && self.launched.elapsed().as_secs_f32() >= secs {
            self.exiting = true;
            match self.options.screenshot.clone() {
                Some(path) => {
                    let ctx2 = ctx.clone();
                    ctx.request_screenshot(move |image| {
                        if let Err(e) = save_color_image(&image, &path) {
                            eprintln!("guava-viewer: screenshot {}: {e:#}", path.display());
                        }
                        ctx2.send_viewport_cmd(egui::ViewportCommand::Close);
                    });
                }
                None => ctx.send_viewport_cmd(egui::ViewportCommand::Close),
            }
        }
    }
}

/// The shipped demo portrait (scikit-image's astronaut, public domain), with its fitted tracking
/// beside it (`assets/demo_portrait.json`, written by `guava fit`).
pub fn demo_portrait() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo_portrait.png")
}

/// The name the synthetic demo photo goes by in the UI and in the avatar it makes.
const SYNTHETIC_PHOTO: &str = "synthetic photo of the default body (known-answer demo)";

/// A progress callback for reconstruction: publishes the stage, stops when cancelled.
fn progress<'a>(
    stage: &'a Mutex<&'static str>,
    cancel: &'a AtomicBool,
) -> impl FnMut(guava::reconstruct::Stage) -> bool + 'a {
    move |s| {
        *stage.lock().unwrap_or_else(|e| e.into_inner()) = s.name();
        !cancel.load(Ordering::Relaxed)
    }
}

/// What reconstructing a photo needs from the app, moved to its worker.
struct PhotoJob {
    body: Arc<ViewerBody>,
    networks: Option<Arc<Mutex<GuavaModels>>>,
    /// EHM-Tracker's keypoint models folder, when the user chose it.
    dwpose: Option<PathBuf>,
    keypoint_models: Arc<Mutex<KeypointModels>>,
}

impl PhotoJob {
    /// The default reconstruction on a template body, GUAVA's on an EHM body.
    fn run(
        &self,
        photo: &Path,
        tracked: guava::reconstruct::Tracked,
        stage: &Mutex<&'static str>,
        cancel: &AtomicBool,
    ) -> Result<Loaded, String> {
        // One job runs at a time, so holding the models for the whole job blocks nobody.
        let mut keypoints = self
            .keypoint_models
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        keypoints.wanted = self.dwpose.clone();
        match &*self.body {
            ViewerBody::Template(body) => {
                reconstruct_worker(body, photo, tracked, &mut keypoints, stage, cancel)
            }
            ViewerBody::Ehm(body) => guava_worker(
                body,
                self.networks.as_deref(),
                photo,
                tracked,
                &mut keypoints,
                stage,
                cancel,
            ),
        }
    }
}

fn reconstruct_worker(
    body: &BodyModel,
    photo: &Path,
    tracked: guava::reconstruct::Tracked,
    keypoints: &mut KeypointModels,
    stage: &Mutex<&'static str>,
    cancel: &AtomicBool,
) -> Result<Loaded, String> {
    use guava::reconstruct::{DEFAULT_UV_SIZE, UvMap, reconstruct_photo_file};
    // The pose and face models fit photos without tracking; the pose model masks photos without
    // alpha (else the body's silhouette does).
    let mut model = keypoints.get(photo, &tracked, stage)?;
    *stage.lock().unwrap_or_else(|e| e.into_inner()) = "building the UV map";
    let uv = UvMap::for_body(body, DEFAULT_UV_SIZE);
    let (avatar, report, view) = reconstruct_photo_file(
        body,
        &uv,
        photo,
        tracked,
        model.as_deref_mut(),
        &mut progress(stage, cancel),
    )
    .map_err(|e| e.to_string())?;
    let camera = (view.camera.view_from_world, view.camera.invtanfov());
    let summary = default_summary(&report, model.as_deref(), view.crop);
    let preview = SourcePreview::new(
        body,
        &body.landmarks,
        photo,
        &report.keypoints,
        report.fit.as_ref(),
        view,
    )
    .map_or(Preview::None, |p| Preview::Fit(Box::new(p)));
    Ok(Loaded::Avatar(
        Box::new(avatar),
        Some(summary),
        preview,
        Some(camera),
    ))
}

/// The keypoint models photo jobs use: loaded by the first job that needs them and kept for the
/// next (MediaPipe's seven take ~0.4 s to load, EHM-Tracker's are hundreds of MB); when the user
/// picks other ones, only EHM-Tracker's are loaded or dropped.
#[derive(Default)]
struct KeypointModels {
    /// EHM-Tracker's folder the next job wants (`None`: MediaPipe's models alone).
    wanted: Option<PathBuf>,
    loaded: Option<guava::keypoints::Landmarkers>,
    /// The EHM-Tracker folder `loaded` holds the models of.
    wholebody: Option<PathBuf>,
}

impl KeypointModels {
    /// The models with EHM-Tracker's from `wanted`, loading what is not loaded yet.
    fn ensure(
        &mut self,
        stage: &Mutex<&'static str>,
    ) -> Result<&mut guava::keypoints::Landmarkers, String> {
        use guava::keypoints::{Landmarkers, Wholebody};
        let runtime = guava::onnx::OnnxRuntime::load().map_err(|e| e.to_string())?;
        let loading = || {
            *stage.lock().unwrap_or_else(|e| e.into_inner()) = "loading the keypoint models";
        };
        if self.loaded.is_none() {
            loading();
            self.wholebody = None;
            self.loaded = Some(Landmarkers::load(runtime).map_err(|e| e.to_string())?);
        }
        let models = self.loaded.as_mut().expect("loaded above");
        if self.wholebody != self.wanted {
            loading();
            // Consistent if loading fails: no EHM-Tracker models, and none recorded.
            models.wholebody = None;
            self.wholebody = None;
            if let Some(dir) = &self.wanted {
                models.wholebody =
                    Some(Wholebody::load_dir(runtime, dir).map_err(|e| e.to_string())?);
            }
            self.wholebody = self.wanted.clone();
        }
        Ok(models)
    }

    /// The models for reconstructing `photo`: fitting needs them (their error is the job's),
    /// otherwise they are optional (a warning, and `None`).
    fn get(
        &mut self,
        photo: &Path,
        tracked: &guava::reconstruct::Tracked,
        stage: &Mutex<&'static str>,
    ) -> Result<Option<&mut guava::keypoints::Landmarkers>, String> {
        match self.ensure(stage) {
            Ok(_) => Ok(self.loaded.as_mut()),
            Err(e) if matches!(tracked, guava::reconstruct::Tracked::Fit) => Err(format!(
                "{}: no tracking file beside it, and fitting needs the keypoint models: {e}",
                photo.display()
            )),
            Err(e) => {
                log::warn!("keypoint models unavailable ({e})");
                Ok(None)
            }
        }
    }
}

/// What a default reconstruction saw and how long it took, for the avatar's label.
fn default_summary(
    r: &guava::reconstruct::Report,
    models: Option<&guava::keypoints::Landmarkers>,
    crop: Option<guava::reconstruct::Crop>,
) -> String {
    let ms: f64 = r.timings.iter().map(|(_, d)| d.as_secs_f64() * 1e3).sum();
    let mut summary = r
        .fit
        .as_ref()
        .map(|f| fit_summary(f, models, crop))
        .unwrap_or_default();
    summary.push_str(&format!(
        "{} of {} texels seen, {} mirrored, rest inpainted; {ms:.0} ms",
        r.observed, r.texels, r.mirrored
    ));
    summary
}

/// How the source view was fitted, and where in the photo when it was framed around the
/// person (`crop`), for the avatar's label (ends with "; ").
fn fit_summary(
    f: &guava::fit::FitReport,
    models: Option<&guava::keypoints::Landmarkers>,
    crop: Option<guava::reconstruct::Crop>,
) -> String {
    let mut summary = String::new();
    if let Some(c) = crop {
        summary.push_str(&format!(
            "framed around the person ({}² at {}, {} of the photo); ",
            c.side, c.left, c.top
        ));
    }
    {
        summary.push_str(&format!(
            "pose and camera fitted to {} keypoints{} ({:.1} px RMS)",
            f.keypoints_used,
            models.map_or(String::new(), |m| format!(" of {}", m.body_points())),
            f.rms_px
        ));
        match (&f.face, &f.face_skipped) {
            (Some(face), _) => summary.push_str(&format!(
                ", expression to {} face points ({:.1} px RMS)",
                face.points_used, face.rms_px
            )),
            (None, Some(why)) => summary.push_str(&format!(", face not fitted ({why})")),
            (None, None) => {}
        }
        if let Some(g) = &f.gaze {
            summary.push_str(&format!(", gaze to {} irises", g.observed.len()));
        }
        summary.push_str("; ");
    }
    summary
}

/// GUAVA mode: the photo with its tracking (or fitted) on the EHM body through GUAVA's networks.
fn guava_worker(
    body: &EhmModel,
    networks: Option<&Mutex<GuavaModels>>,
    photo: &Path,
    tracked: guava::reconstruct::Tracked,
    keypoints: &mut KeypointModels,
    stage: &Mutex<&'static str>,
    cancel: &AtomicBool,
) -> Result<Loaded, String> {
    use guava::guava_mode::{reconstruct_guava_file, uv_map};
    let fitting = matches!(tracked, guava::reconstruct::Tracked::Fit);
    let networks = networks.ok_or_else(|| {
        format!(
            "{}: GUAVA mode needs GUAVA's networks: open their folder (Mode > Networks folder…, \
             written by tools/export_guava_onnx.py)",
            photo.display()
        )
    })?;
    // The keypoint models fit a photo without tracking, and mask a photo without alpha.
    let has_alpha = guava::reconstruct::SourceImage::has_alpha(photo).map_err(|e| e.to_string())?;
    let mut landmarkers = if has_alpha && !fitting {
        None
    } else {
        // reconstruct_guava_file says what is missing if the photo needs its mask.
        keypoints.get(photo, &tracked, stage)?
    };
    let mut models = networks.lock().unwrap_or_else(|e| e.into_inner());
    let uv = uv_map(body, models.dims.uv as u32);
    let (avatar, r, view) = reconstruct_guava_file(
        &mut models,
        body,
        &uv,
        photo,
        tracked,
        landmarkers.as_deref_mut(),
        &mut progress(stage, cancel),
    )
    .map_err(|e| e.to_string())?;
    let ms: f64 = r.timings.iter().map(|(_, d)| d.as_secs_f64() * 1e3).sum();
    let summary = format!(
        "networks: {}; {}{} of {} texels on faces the photo shows, {} Gaussians pruned; {ms:.0} ms",
        models.source,
        r.fit
            .as_ref()
            .map(|f| fit_summary(f, landmarkers.as_deref(), view.crop))
            .unwrap_or_default(),
        r.observed_texels,
        r.texels,
        r.pruned
    );
    let camera = (view.camera.view_from_world, view.camera.invtanfov());
    let preview = match &r.fit {
        Some(fit) => SourcePreview::new(body, &fit.surface, photo, &r.keypoints, Some(fit), view)
            .map_or(Preview::None, |p| Preview::Fit(Box::new(p))),
        None => TrackedPhoto::new(photo, view.crop, &r.projected)
            .map_or(Preview::None, Preview::Tracked),
    };
    Ok(Loaded::Avatar(
        Box::new(avatar),
        Some(summary),
        preview,
        Some(camera),
    ))
}

/// An `.npz` file: an EHM body (its `format` entry says so) or an SMPL-X motion.
fn open_npz(path: &Path) -> Result<Loaded, String> {
    let npz = guava::npz::Npz::open(path).map_err(|e| e.to_string())?;
    if npz.contains("format") {
        EhmModel::from_opened(&npz, path)
            .map(|m| Loaded::Body(ViewerBody::Ehm(Box::new(m))))
            .map_err(|e| e.to_string())
    } else {
        guava::tracking::import::smplx_from_npz(&npz)
            .map(Loaded::Motion)
            .map_err(|e| e.to_string())
    }
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

fn save_color_image(image: &egui::ColorImage, path: &Path) -> anyhow::Result<()> {
    let [w, h] = image.size;
    let rgba: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_array()).collect();
    let img = image::RgbaImage::from_raw(w as u32, h as u32, rgba)
        .ok_or_else(|| anyhow::anyhow!("bad screenshot size"))?;
    let rgb = image::DynamicImage::ImageRgba8(img).to_rgb8();
    guava::render::save_png(&rgb, path)
}

impl eframe::App for GuavaApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let now = Instant::now();
        if let Some(last) = self.last_frame {
            self.frame_ms = 0.9 * self.frame_ms + 0.1 * (now - last).as_secs_f32() * 1e3;
        }
        self.last_frame = Some(now);
        self.poll_loading();
        self.open_dropped_and_queued(&ctx);

        // While the fit is edited by hand the body holds the photo's pose, not the motion's.
        let editing = self.editing_fit();
        if let (Some(motion), Some(body), false) = (&mut self.motion, &mut self.body, editing) {
            let dt = ctx.input(|i| i.unstable_dt) as f64;
            motion.update(dt, &mut body.pose);
            if motion.is_playing() {
                ctx.request_repaint();
            }
        }

        egui::Panel::top("menu").show(ui, |ui| self.menu_ui(ui));
        egui::Panel::bottom("status").show(ui, |ui| {
            ui.horizontal(|ui| {
                if let Some(loading) = &self.loading {
                    ui.spinner();
                    let stage = *loading.stage.lock().unwrap_or_else(|e| e.into_inner());
                    ui.label(format!(
                        "{} — {stage} ({:.1} s)",
                        loading.path.display(),
                        loading.started.elapsed().as_secs_f32()
                    ));
                    if ui.button("Cancel").clicked() {
                        loading.cancel.store(true, Ordering::Relaxed);
                        self.loading = None;
                        self.status = Some(("loading cancelled".into(), false));
                    }
                    ctx.request_repaint();
                } else if let Some((text, is_error)) = &self.status {
                    let color = if *is_error {
                        ui.visuals().error_fg_color
                    } else {
                        ui.visuals().text_color()
                    };
                    ui.colored_label(color, text);
                }
            });
        });
        if let (Some(motion), View::Body | View::Avatar) = (&mut self.motion, self.view) {
            egui::Panel::bottom("timeline").show(ui, |ui| motion.timeline_ui(ui));
        }
        egui::Panel::left("scene").resizable(true).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.side_panel_ui(ui));
        });
        egui::CentralPanel::default()
            .frame(egui::Frame::NONE)
            .show(ui, |ui| self.viewport_ui(ui));

        let (redraw, gpu_error) = {
            let mut report = self.report.lock().unwrap_or_else(|e| e.into_inner());
            (
                std::mem::take(&mut report.needs_redraw),
                report.error.take(),
            )
        };
        if let Some(e) = gpu_error {
            self.error(e);
        }
        if redraw {
            ctx.request_repaint();
        }
        self.automation(&ctx);
    }
}
