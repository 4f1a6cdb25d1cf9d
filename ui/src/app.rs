//! The viewer window's shell: what is open, how it is viewed, and the frame loop that lays out
//! the menu, the side panel, the timeline, the status bar and the viewport. Opening files and
//! running jobs live in `files`, the panels in `panels`; the GPU work in the library's
//! `render::view`.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use guava::eval::Metrics;
use guava::view::{ViewRenderer, ViewReport};

use crate::avatar_view::SourcePreview;
use crate::body_panel::BodyState;
use crate::document::Document;
use crate::exports::{self, Export, ExportSettings, Started};
use crate::files::{Opening, Taken};
use crate::jobs::{Done, Jobs};
use crate::motion::Motion;
use crate::offscreen::OffscreenRenderer;
use crate::refined::RefinedView;
use crate::settings::{Recent, Remembered, Settings};
use crate::shortcuts::Shortcut;
use crate::viewing::{CameraMode, View, Viewing};

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
    /// The exports controller's settings (and whether its window is open).
    pub(crate) export: ExportSettings,
    /// Files opened recently, newest first (remembered between runs).
    pub(crate) recent: Recent,
    /// Whether the help window (shortcuts, mouse) is open.
    pub(crate) help: bool,
    /// The last `guava report`'s plot, read when its section is first opened.
    pub(crate) report_plot: Option<crate::report_plot::ReportPlot>,
    pub(crate) report: Arc<Mutex<ViewReport>>,
    /// The job in flight and the files waiting to open (several dropped at once).
    pub(crate) jobs: Jobs,
    /// The status bar's message, and whether it is an error.
    pub(crate) status: Option<(String, bool)>,
    pub(crate) gpu: Gpu,
    pub(crate) clock: FrameClock,
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
            viewing: Viewing::new(gpu.cpu),
            drive: None,
            refined: RefinedView::default(),
            export: Default::default(),
            recent: Recent::default(),
            help: false,
            report_plot: None,
            gpu,
            report: Arc::default(),
            jobs: Jobs::default(),
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
        app.jobs.enqueue(options.open.iter().cloned());
        if options.demo_avatar && options.open.is_empty() && !options.test_scene {
            app.jobs.enqueue([crate::files::demo_portrait()]);
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
        self.jobs.busy()
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
            self.viewing.frame(&mut self.doc);
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
        if let Some(settings) = Settings::load(storage) {
            settings.apply(self.remembered());
        }
    }

    /// The parts of the app whose settings are remembered between runs.
    fn remembered(&mut self) -> Remembered<'_> {
        Remembered {
            viewing: &mut self.viewing,
            refined: &mut self.refined,
            export: &mut self.export,
            recent: &mut self.recent,
        }
    }

    /// Files opened recently, newest first.
    pub fn recent_files(&self) -> &[PathBuf] {
        self.recent.files()
    }

    /// Stops the running job at its next step (what it loaded is dropped; what an export
    /// wrote so far stays, each file whole).
    pub fn cancel_job(&mut self) {
        if let Some(path) = self.jobs.cancel() {
            self.info(format!("{}: cancelled", path.display()));
        }
    }

    /// The export window's settings (size, camera path, rate).
    pub fn export_settings(&mut self) -> &mut ExportSettings {
        &mut self.export
    }

    /// Writes what `export` names: images as a job (its outcome in the status bar), files of
    /// the avatar or the body at once. Why it could not start also goes to the status bar.
    pub fn export(&mut self, export: Export) -> Result<(), String> {
        let networks = self.doc.networks.as_ref().map(|n| n.dir.as_path());
        let refiner = self
            .doc
            .avatar
            .as_ref()
            .and_then(|a| self.refined.for_export(a.avatar.kind, networks));
        let source = exports::Source {
            doc: &mut self.doc,
            viewing: &self.viewing,
            offscreen: self.gpu.offscreen.clone(),
            refiner,
        };
        let result = match exports::run(export, &self.export, source) {
            Ok(Started::Job(path, work)) => self
                .jobs
                .spawn(path, "exporting", move |c| work(c).map(Done::Exported))
                .map(|()| "exporting".to_string()),
            Ok(Started::Wrote(message)) => Ok(message),
            Err(e) => Err(e),
        };
        self.report_result(result)
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
        self.doc.time()
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

    /// Starts opening a file (or GUAVA's networks folder) on a worker thread; what is open stays
    /// until it succeeds. Opened while a job runs, it opens next.
    pub fn open(&mut self, path: PathBuf) {
        if self.jobs.running().is_some() {
            return self.jobs.enqueue([path]);
        }
        let photo = self.doc.photo_job(self.gpu.offscreen.clone());
        let opening = crate::files::opening(path, &self.doc, photo);
        self.start(opening);
    }

    /// Reconstructs the avatar's source photo again with `view` (the fit adjusted by hand).
    pub fn reconstruct_with_pose(&mut self, photo: PathBuf, view: guava::tracking::SourceView) {
        let job = self.doc.photo_job(self.gpu.offscreen.clone());
        let tracked = guava::pipeline::Tracked::Given(view);
        self.start(crate::files::reconstruction(photo, tracked, job));
    }

    /// Reconstructs a synthetic photo of the current body (the known-answer demo), so a fresh
    /// install can make an avatar offline.
    pub fn reconstruct_synthetic_photo(&mut self) {
        let job = self.doc.photo_job(self.gpu.offscreen.clone());
        self.start(crate::files::synthetic_reconstruction(job));
    }

    /// Runs an opening job, or says why it cannot run.
    pub(crate) fn start(&mut self, opening: Result<Opening, String>) {
        let started = opening.and_then(|Opening { path, stage, work }| {
            self.jobs
                .spawn(path, stage, move |c| work(c).map(Done::Opened))
        });
        if let Err(e) = started {
            self.error(e);
        }
    }

    /// Opens what was dropped, and the next queued file once no job runs.
    fn open_dropped_and_queued(&mut self, ctx: &egui::Context) {
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .collect()
        });
        self.jobs.enqueue(dropped);
        // One job at a time: the next queued file opens when the last one is taken in.
        if let Some(path) = self.jobs.next_queued() {
            self.open(path);
        }
    }

    /// Takes in the finished job's message: what it loaded into the document, what an export
    /// wrote, or its error.
    fn take_job_result(&mut self) {
        let Some((path, result)) = self.jobs.finished() else {
            return;
        };
        match result {
            Ok(Done::Opened(loaded)) => {
                if path.exists() {
                    self.recent.remember(path.clone());
                }
                // The first launch's demo avatar is seen through its photo's camera, as GUAVA
                // renders.
                let look_from_photo = self.options.demo_avatar && self.doc.avatar.is_none();
                let taken = self
                    .doc
                    .take(&path, loaded, &self.gpu.limits, look_from_photo);
                self.show(taken);
            }
            Ok(Done::Exported(message)) => self.info(message),
            Err(e) => self.error(e),
        }
    }

    /// Shows what the document took in as it asks (the view, framed, from which camera), or
    /// why it was not taken.
    fn show(&mut self, taken: Result<Taken, String>) {
        let taken = match taken {
            Ok(t) => t,
            Err(e) => return self.error(e),
        };
        if let Some(view) = taken.show {
            self.viewing.view = view;
        }
        if let Some(mode) = taken.camera {
            self.viewing.camera_mode = mode;
        }
        if taken.frame {
            self.viewing.frame(&mut self.doc);
        }
        if let Some(scene) = &self.doc.scene {
            let last = scene.cloud.channels as u32 - 1;
            let display = &mut self.viewing.display;
            display.rgb_channels = display.rgb_channels.map(|c| c.min(last));
        }
        self.info(taken.status);
    }

    /// Shows the embedded default body (Anny).
    pub(crate) fn load_default_body(&mut self) {
        let taken = guava::body::BodyModel::default_body()
            .map(|m| {
                let body = guava::body::AnyBody::Template(Arc::new(m));
                self.doc.set_body(body, "default body template")
            })
            .map_err(|e| e.to_string());
        self.show(taken);
    }

    /// Puts the demo motion on the timeline, playing or at the time the options ask.
    fn load_demo_motion(&mut self) {
        let label = "demo motion — authored keyframes (tools/make_demo_motion.py), not tracked \
                     from a video";
        let taken = guava::tracking::demo_motion()
            .map_err(|e| e.to_string())
            .and_then(|tracking| {
                let notes = Vec::new();
                let imported = guava::tracking::import::Imported { tracking, notes };
                self.doc.set_motion(label.into(), imported)
            });
        self.show(taken);
        if let Some(motion) = &mut self.doc.motion {
            motion.player.playing = self.options.autoplay;
            if let Some(t) = self.options.motion_time {
                motion.player.playing = false;
                motion.player.seek(t as f64);
            }
        }
    }

    /// Shows a synthetic splat scene (not an avatar), to try the splatting pass.
    pub fn open_test_scene(&mut self) {
        let cloud = guava::gaussians::synthetic::torus_knot(40_000, 1);
        let kind = "synthetic test scene (not an avatar)";
        let taken = self.doc.set_scene("test scene".into(), kind, cloud);
        self.show(Ok(taken));
    }

    /// Writes the avatar shown to `path` (atomically: the old file stays if this fails).
    pub fn save_avatar(&mut self, path: &std::path::Path) -> Result<(), String> {
        self.report_result(self.doc.save_avatar(path))
    }

    /// Says in the status bar what was done, or why not; the error also comes back.
    pub(crate) fn report_result(&mut self, result: Result<String, String>) -> Result<(), String> {
        match result {
            Ok(message) => {
                self.info(message);
                Ok(())
            }
            Err(e) => {
                self.error(e.clone());
                Err(e)
            }
        }
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
        if self.clock.opened.is_none() && !self.jobs.busy() {
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

    fn run_shortcut(&mut self, shortcut: Shortcut) {
        match shortcut {
            Shortcut::PlayPause => {
                if let Some(m) = &mut self.doc.motion {
                    m.toggle_play();
                }
            }
            Shortcut::Step(n) => {
                if let Some(m) = &mut self.doc.motion {
                    m.player.step(n);
                }
            }
            Shortcut::Frame => {
                self.viewing.camera_mode = CameraMode::Orbit;
                self.viewing.frame(&mut self.doc);
            }
            Shortcut::View(i) => self.viewing.preset(i),
            Shortcut::ToggleRefine => self.refined.enabled = !self.refined.enabled,
            Shortcut::Open => self.open_dialog(),
            Shortcut::Save => self.save_avatar_dialog(),
            Shortcut::Export => self.export.open = self.doc.avatar.is_some(),
            Shortcut::Help => self.help = !self.help,
            Shortcut::Cancel => self.cancel_job(),
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
        Settings::save(self.remembered(), storage);
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
        if let Some(export) = self.export.window(&ctx, &self.doc.avatar_stem()) {
            // Its error is in the status bar.
            let _ = self.export(export);
        }
        crate::shortcuts::help_window(&ctx, &mut self.help);
        for shortcut in crate::shortcuts::pressed(&ctx) {
            self.run_shortcut(shortcut);
        }

        self.take_view_report(&ctx);
        self.automation(&ctx);
    }
}
