//! The viewer window's shell: what is open, how it is viewed, and the frame loop that lays out
//! the menu, the side panel, the timeline, the status bar and the viewport. Opening files and
//! running jobs live in `files`, the panels in `panels`; the GPU work in the library's
//! `render::view`.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use guava::eval::Metrics;
use guava::gaussians::GaussianCloud;
use guava::guava_mode::GuavaModels;
use guava::pipeline::Pipeline;
use guava::view::{Display, ViewRenderer, ViewReport};

use crate::avatar_view::{AvatarState, SourcePreview};
use crate::body_panel::BodyState;
use crate::jobs::Job;
use crate::motion::Motion;
use crate::offscreen::OffscreenRenderer;
use crate::orbit::OrbitCamera;
use crate::refined::RefinedView;

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
    /// Destroy the GPU device this many seconds after what was asked to open has opened (fault
    /// injection: what a driver reset does; the window must not hang and the user's avatar must
    /// be saved).
    pub lose_device_after: Option<f32>,
    /// With nothing else to open, start on the demo portrait's avatar (the window does; tests
    /// start on the bare body).
    pub demo_avatar: bool,
    /// Drive the body from this video once what was asked to open has opened.
    pub drive: Option<PathBuf>,
}

pub(crate) struct Scene {
    pub name: String,
    /// Where it came from and what it is, shown in the panel (never "GUAVA avatar" unless it is one).
    pub kind: &'static str,
    pub cloud: Arc<GaussianCloud>,
    pub id: u64,
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
    /// The camera path keyed by hand, at the timeline's time.
    Keys,
}

/// GUAVA mode's networks, shared with reconstruction workers (a session runs one call at a time).
pub(crate) struct Networks {
    pub models: Arc<Mutex<GuavaModels>>,
    /// The folder (its refiner refines GUAVA-mode avatars).
    pub dir: std::path::PathBuf,
    /// The folder and where its weights came from, shown in the panel.
    pub label: String,
}

/// The device the viewport draws on.
pub(crate) struct Gpu {
    pub ready: bool,
    pub adapter: String,
    pub limits: wgpu::Limits,
    pub cpu: bool,
    /// The device (egui's), for loading the refiner onto it.
    pub context: Option<guava::gpu::GpuContext>,
    /// The same device and splatting pipelines for rendering off screen on a worker (exports,
    /// an avatar against its photo).
    pub offscreen: Option<Arc<Mutex<OffscreenRenderer>>>,
}

/// How the viewport is drawn while the user drags, orbits or plays: at a fraction of its
/// resolution, back to full once input settles.
pub(crate) struct Interaction {
    /// The resolution scale while interacting (1 = always full).
    pub scale: f32,
    /// Whether the last frame was drawn at the interactive scale.
    pub active: bool,
}

pub struct GuavaApp {
    pub(crate) options: Options,
    /// What is open: the splat scene, the body, the avatar, the motion, the networks.
    pub(crate) doc: Document,
    /// How it is looked at: which view, the camera, the display, a split.
    pub(crate) viewing: Viewing,
    /// A video or webcam driving the body live (the motion waits meanwhile).
    pub(crate) drive: Option<crate::drive::Drive>,
    /// The refiner pass, run when the view settles.
    pub(crate) refined: RefinedView,
    /// The export window's settings.
    pub(crate) export: crate::exports::ExportSettings,
    /// Files opened recently, newest first (remembered between runs).
    pub(crate) recent: Vec<PathBuf>,
    /// Whether the help window (shortcuts, mouse) is open.
    pub(crate) help: bool,
    /// The last `guava report`'s plot, read when its section is first opened.
    pub(crate) report_plot: Option<crate::report_plot::ReportPlot>,
    pub(crate) report: Arc<Mutex<ViewReport>>,
    pub(crate) job: Option<Job>,
    /// Files waiting to open once the current job is done (several dropped at once).
    pub(crate) queue: VecDeque<PathBuf>,
    /// The status bar's message, and whether it is an error.
    pub(crate) status: Option<(String, bool)>,
    pub(crate) gpu: Gpu,
    pub(crate) clock: FrameClock,
}

/// What is open in the viewer: what jobs load into and every view draws.
#[derive(Default)]
pub(crate) struct Document {
    pub scene: Option<Scene>,
    pub body: Option<BodyState>,
    pub avatar: Option<AvatarState>,
    /// The motion driving the body (the demo motion until another is opened).
    pub motion: Option<Motion>,
    /// GUAVA's networks, once the user opened their folder (GUAVA mode with an EHM body).
    pub networks: Option<Networks>,
    /// EHM-Tracker's keypoint models folder, once the user chose it: its DWPose places the body
    /// and hand points when photos are fitted.
    pub dwpose: Option<PathBuf>,
    /// Photo → avatar (keypoint models and the UV map kept between photos), shared with jobs.
    pub pipeline: Arc<Mutex<Pipeline>>,
}

/// How the document is looked at: none of it changes what is open.
pub(crate) struct Viewing {
    pub view: View,
    pub orbit: OrbitCamera,
    pub camera_mode: CameraMode,
    /// The camera path keyed by hand (camera mode *keys*, sequence exports).
    pub camera_keys: crate::camera_keys::CameraKeys,
    pub display: Display,
    /// A split between two views, and the mesh over the avatar.
    pub views: crate::compare::Views,
    /// Whether the avatar's photo is shown beside it in the viewport.
    pub display_photo_beside: bool,
    pub background: [f32; 3],
    pub interaction: Interaction,
}

/// The UI's own frame timing, and the scripted exit.
pub(crate) struct FrameClock {
    pub frames: u64,
    /// When the window was created (for `exit_after_secs`).
    pub launched: Instant,
    pub exiting: bool,
    pub last_frame: Option<Instant>,
    pub frame_ms: f32,
    /// When what was asked to open at launch had opened.
    pub opened: Option<Instant>,
}

impl GuavaApp {
    pub fn new(cc: &eframe::CreationContext<'_>, options: Options) -> Self {
        let gpu = match cc.wgpu_render_state.as_ref() {
            Some(rs) => {
                let info = rs.adapter.get_info();
                let view = ViewRenderer::new(&rs.device, &rs.queue, &info, rs.target_format);
                let pipelines = view.pipelines();
                rs.renderer.write().callback_resources.insert(view);
                crate::recovery::watch(&rs.device);
                // One context for the device: egui's, shared by the view, the refiner and the
                // off-screen renderer (which shares the view's pipelines too).
                let context = guava::gpu::GpuContext {
                    adapter: rs.adapter.clone(),
                    device: rs.device.clone(),
                    queue: rs.queue.clone(),
                };
                Gpu {
                    ready: true,
                    adapter: guava::gpu::adapter_label(&info),
                    limits: rs.device.limits(),
                    cpu: info.device_type == wgpu::DeviceType::Cpu,
                    offscreen: Some(Arc::new(Mutex::new(OffscreenRenderer::new(
                        context.clone(),
                        pipelines,
                    )))),
                    context: Some(context),
                }
            }
            None => Gpu {
                ready: false,
                adapter: "no wgpu device".into(),
                limits: wgpu::Limits::default(),
                cpu: false,
                context: None,
                offscreen: None,
            },
        };
        let mut app = Self {
            options: options.clone(),
            doc: Document::default(),
            viewing: Viewing {
                view: View::Body,
                orbit: OrbitCamera::default(),
                camera_mode: CameraMode::Orbit,
                camera_keys: Default::default(),
                display: Display::default(),
                views: Default::default(),
                display_photo_beside: false,
                background: [0.0; 3],
                // A software adapter cannot splat the full viewport at interactive rates.
                interaction: Interaction {
                    scale: if gpu.cpu { 0.5 } else { 1.0 },
                    active: false,
                },
            },
            drive: None,
            refined: RefinedView::default(),
            export: Default::default(),
            recent: Vec::new(),
            help: false,
            report_plot: None,
            gpu,
            report: Arc::default(),
            job: None,
            queue: VecDeque::new(),
            status: None,
            clock: FrameClock {
                frames: 0,
                launched: Instant::now(),
                exiting: false,
                last_frame: None,
                frame_ms: 0.0,
                opened: None,
            },
        };
        if let Some(storage) = cc.storage {
            app.restore_settings(storage);
        }
        app.load_default_body();
        app.load_demo_motion();
        if options.test_scene {
            app.open_test_scene();
        }
        app.queue = options.open.iter().cloned().collect();
        if options.demo_avatar && app.queue.is_empty() && !options.test_scene {
            app.queue.push_back(crate::files::demo_portrait());
        }
        app
    }

    pub fn motion(&self) -> Option<&Motion> {
        self.doc.motion.as_ref()
    }

    pub fn motion_mut(&mut self) -> Option<&mut Motion> {
        self.doc.motion.as_mut()
    }

    /// The body panel's description of the current body (its source and model name).
    pub fn body_label(&self) -> Option<&str> {
        self.doc.body.as_ref().map(|b| b.label.as_str())
    }

    pub fn body_mut(&mut self) -> Option<&mut BodyState> {
        self.doc.body.as_mut()
    }

    /// The avatar panel's description (its kind and source) and its Gaussian count.
    pub fn avatar_info(&self) -> Option<(&str, usize)> {
        self.doc
            .avatar
            .as_ref()
            .map(|a| (a.label.as_str(), a.drawn()))
    }

    /// The view the avatar was made from (its photo's pose and camera), when it keeps one.
    pub fn avatar_source_view(&self) -> Option<&guava::tracking::SourceView> {
        self.doc.avatar.as_ref()?.avatar.source_view.as_ref()
    }

    /// How the avatar compares with its photo from the photo's camera (and how the previous
    /// avatar of the same photo did), or why it was not compared; `None` for avatars not made here.
    pub fn avatar_fidelity(&self) -> Option<Result<(Metrics, Option<Metrics>), &str>> {
        let fidelity = self.doc.avatar.as_ref()?.fidelity.as_ref()?;
        Some(match fidelity {
            Ok(f) => Ok((f.metrics, f.before)),
            Err(e) => Err(e.as_str()),
        })
    }

    pub fn scene_len(&self) -> Option<usize> {
        self.doc.scene.as_ref().map(|s| s.cloud.len())
    }

    /// Whether a file is loading or waiting to load.
    pub fn busy(&self) -> bool {
        self.job.is_some() || !self.queue.is_empty()
    }

    pub fn status(&self) -> Option<&str> {
        self.status.as_ref().map(|(s, _)| s.as_str())
    }

    pub fn view(&self) -> View {
        self.viewing.view
    }

    /// Switches the viewport and frames what it now shows.
    pub fn set_view(&mut self, view: View) {
        if self.viewing.view != view {
            self.viewing.view = view;
            self.reset_camera();
        }
    }

    pub fn camera_mode(&self) -> CameraMode {
        self.viewing.camera_mode
    }

    /// Looks through the orbit, the source photo's or the motion's tracked camera (the panel's
    /// choice); a camera the current content lacks falls back to the orbit.
    pub fn set_camera_mode(&mut self, mode: CameraMode) {
        self.viewing.camera_mode = mode;
    }

    /// Takes what an earlier run remembered (the look, exports, recent files).
    pub fn restore_settings(&mut self, storage: &dyn eframe::Storage) {
        if let Some(settings) = crate::settings::Settings::load(storage) {
            settings.apply(self);
        }
    }

    /// Stops the running job at its next step (what it loaded is dropped; what an export
    /// wrote so far stays, each file whole).
    pub fn cancel_job(&mut self) {
        if let Some(job) = self.job.take() {
            job.cancel();
            self.info(format!("{}: cancelled", job.path.display()));
        }
    }

    /// The export window's settings (size, camera path, rate).
    pub fn export_settings(&mut self) -> &mut crate::exports::ExportSettings {
        &mut self.export
    }

    /// The orbit camera (what dragging, the camera panel and its presets move).
    pub fn orbit_mut(&mut self) -> &mut crate::orbit::OrbitCamera {
        self.viewing.camera_mode = CameraMode::Orbit;
        &mut self.viewing.orbit
    }

    /// Turns the orbit camera (what dragging or the yaw slider does).
    pub fn set_yaw_deg(&mut self, yaw: f32) {
        self.viewing.orbit.yaw_rad = yaw.to_radians();
    }

    /// What the viewport last reported: counters, renders, the size it drew at.
    /// Refined frames shown so far (the refiner pass runs once the view settles).
    pub fn refined_frames(&self) -> u64 {
        self.report().refine.frames
    }

    /// Where the refiner runs.
    pub fn set_refiner_on(&mut self, on: guava::refine::RefinerOn) {
        self.refined.on = on;
    }

    /// Where the last refined frame was refined (`Refiner::engine_name`).
    pub fn refined_engine(&self) -> Option<String> {
        self.report().refine.engine
    }

    /// Refines while the user drags or plays too (the latest refined frame stays on screen).
    pub fn set_refine_while_interacting(&mut self, on: bool) {
        self.refined.while_interacting = on;
    }

    /// Shows the avatar's photo beside it in the viewport (where it was made here).
    pub fn set_photo_beside(&mut self, beside: bool) {
        self.viewing.display_photo_beside = beside;
    }

    /// The camera path keyed by hand.
    pub fn camera_keys_mut(&mut self) -> &mut crate::camera_keys::CameraKeys {
        &mut self.viewing.camera_keys
    }

    /// The timeline's time (0 without a motion).
    pub fn time(&self) -> f64 {
        self.doc.motion.as_ref().map_or(0.0, |m| m.player.time())
    }

    /// Two views side by side (`None`: one view, as the display panel sets it).
    pub fn set_compare(&mut self, compare: Option<crate::compare::Compare>) {
        self.viewing.views.compare = compare;
    }

    pub fn compare(&self) -> Option<crate::compare::Compare> {
        self.viewing.views.compare
    }

    /// The body's mesh over the avatar at an opacity (`None`: off).
    pub fn set_mesh_over(&mut self, opacity: Option<f32>) {
        self.viewing.views.mesh_over = opacity;
    }

    pub fn report(&self) -> ViewReport {
        self.report.lock().map(|r| r.clone()).unwrap_or_default()
    }

    /// Whether the body sliders are posing the source photo's body (the fit edited by hand).
    pub fn editing_fit(&self) -> bool {
        self.doc
            .avatar
            .as_ref()
            .and_then(|a| a.source.as_ref())
            .is_some_and(SourcePreview::editing)
    }

    pub(crate) fn error(&mut self, message: String) {
        log::warn!("{message}");
        self.status = Some((message, true));
    }

    pub(crate) fn info(&mut self, message: String) {
        self.status = Some((message, false));
    }

    /// Scripted runs: says "ready" once the window is up, and closes (after a screenshot) when
    /// `exit_after_secs` have passed.
    fn automation(&mut self, ctx: &egui::Context) {
        self.clock.frames += 1;
        if self.clock.frames == 3 {
            // The real-window test waits for this line before taking its own screenshot.
            println!("guava-viewer: ready");
        }
        // What was asked to open has opened (the first launch: the demo portrait's avatar).
        if self.clock.opened.is_none() && self.job.is_none() && self.queue.is_empty() {
            self.clock.opened = Some(Instant::now());
            if let Some(video) = self.options.drive.take() {
                self.drive_from(crate::drive::DriveSource::File(video));
            }
            if let Some(a) = &self.doc.avatar {
                // The real-window test waits for this line to photograph the avatar.
                println!("guava-viewer: showing {}", a.avatar.source);
            }
        }
        if let (Some(secs), Some(offscreen), Some(opened)) = (
            self.options.lose_device_after,
            &self.gpu.offscreen,
            self.clock.opened,
        ) && opened.elapsed().as_secs_f32() >= secs
        {
            // Fault injection: the device destroyed as a driver reset would.
            let offscreen = offscreen.lock().unwrap_or_else(|e| e.into_inner());
            offscreen.renderer.gpu.device.destroy();
            self.options.lose_device_after = None;
        }
        let Some(secs) = self.options.exit_after_secs else {
            return;
        };
        ctx.request_repaint();
        // Wall-clock, not frames: a fast GPU would otherwise close before a test can look at it.
        if !self.clock.exiting && self.clock.launched.elapsed().as_secs_f32() >= secs {
            self.clock.exiting = true;
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

    /// Plays the motion (or a live drive) onto the body, unless the fit is being adjusted by
    /// hand (then the body holds the photo's pose).
    fn advance_motion(&mut self, ctx: &egui::Context) {
        let editing = self.editing_fit();
        if let (Some(drive), Some(body), false) = (&mut self.drive, &mut self.doc.body, editing) {
            drive.update(body.model.as_ref(), &mut body.pose);
            if drive.running() {
                ctx.request_repaint();
            }
            return;
        }
        if let (Some(motion), Some(body), false) =
            (&mut self.doc.motion, &mut self.doc.body, editing)
        {
            let dt = ctx.input(|i| i.unstable_dt) as f64;
            motion.update(dt, &mut body.pose);
            if motion.is_playing() {
                ctx.request_repaint();
            }
        }
    }

    /// Takes what the viewport reported: a GPU error once, a request for another frame.
    fn take_view_report(&mut self, ctx: &egui::Context) {
        let (redraw, gpu_error, refine_error) = {
            let mut report = self.report.lock().unwrap_or_else(|e| e.into_inner());
            (
                std::mem::take(&mut report.needs_redraw),
                report.error.take(),
                report.refine.error.take(),
            )
        };
        if let Some(e) = gpu_error {
            self.error(e);
        }
        if let Some(e) = refine_error {
            self.refined.failed(e);
        }
        if redraw {
            ctx.request_repaint();
        }
    }
}

fn save_color_image(image: &egui::ColorImage, path: &std::path::Path) -> anyhow::Result<()> {
    let [w, h] = image.size;
    let rgba: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_array()).collect();
    let img = image::RgbaImage::from_raw(w as u32, h as u32, rgba)
        .ok_or_else(|| anyhow::anyhow!("bad screenshot size"))?;
    let rgb = image::DynamicImage::ImageRgba8(img).to_rgb8();
    guava::render::save_png(&rgb, path)
}

impl eframe::App for GuavaApp {
    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        crate::settings::Settings::save(self, storage);
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let now = Instant::now();
        if let Some(last) = self.clock.last_frame {
            self.clock.frame_ms =
                0.9 * self.clock.frame_ms + 0.1 * (now - last).as_secs_f32() * 1e3;
        }
        self.clock.last_frame = Some(now);
        self.take_job_result();
        self.open_dropped_and_queued(&ctx);
        self.advance_motion(&ctx);

        egui::Panel::top("menu").show(ui, |ui| self.menu_ui(ui));
        egui::Panel::bottom("status").show(ui, |ui| self.status_ui(ui));
        if let (Some(motion), View::Body | View::Avatar) = (&mut self.doc.motion, self.viewing.view)
        {
            egui::Panel::bottom("timeline").show(ui, |ui| motion.timeline_ui(ui));
        }
        egui::Panel::left("scene").resizable(true).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.side_panel_ui(ui));
        });
        egui::CentralPanel::default()
            .frame(egui::Frame::NONE)
            .show(ui, |ui| self.viewport_ui(ui));
        self.export_ui(&ctx);
        self.help_ui(&ctx);
        self.shortcuts(&ctx);

        self.take_view_report(&ctx);
        self.automation(&ctx);
    }
}
