//! The exports controller: what the viewer writes out, each writing atomically — the view as a
//! PNG at any size, refined as on screen, and the timeline as a PNG sequence (and an animated GIF
//! and an MP4) along a camera path, as jobs (progress in the status bar, Cancel); the posed
//! avatar as a 3DGS PLY other splat viewers open, the posed body as glTF and the animatable
//! avatar as rigged glTF, at once. It owns the export window's settings; the window and the API
//! ask for an [`Export`], and [`run`] answers with a job to start or what it wrote, from the
//! document as it is (it never changes it).

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use guava::body::{BodyPose, Posable, PosedBody};
use guava::camera::Camera;
use guava::gaussians::GaussianCloud;
use guava::render::sequence;
use guava::tracking::{Retarget, Tracking};
use guava::view::{AvatarRef, PoseRef, RefineWith};

use crate::document::Document;
use crate::ids::next_id;
use crate::jobs::{JobContext, Work};
use crate::offscreen::OffscreenRenderer;
use crate::orbit::OrbitCamera;
use crate::pose_controls::PoseControls;
use crate::viewing::{View, Viewing};
use guava::body::AnyBody;

/// How the camera moves over an exported sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraPath {
    /// The view as it is.
    Fixed,
    /// Once around the orbit's target over the sequence.
    Turntable,
    /// The motion's tracked camera.
    Tracked,
    /// The camera path keyed by hand (Camera panel).
    Keys,
}

/// What to write where: the export window's message (and the API's).
#[derive(Clone, Debug)]
pub enum Export {
    /// The view as a PNG at the export size.
    Png(PathBuf),
    /// The timeline as a PNG sequence (and a GIF and an MP4) in a folder.
    Sequence(PathBuf),
    /// The posed avatar as a 3DGS PLY.
    Ply(PathBuf),
    /// The posed body as a glTF mesh.
    Mesh(PathBuf),
    /// The avatar as a rigged glTF, the timeline's motion its animation.
    Animatable(PathBuf),
}

/// What an export asks of the app: a job to run (its file or folder, and the work, which returns
/// what it wrote), or nothing more (it wrote at once and says what).
pub(crate) enum Started {
    Job(PathBuf, Box<Work<String>>),
    Wrote(String),
}

/// What exports draw from: the document as it is, how it is viewed, the device, and the
/// refiner when the view refines.
pub(crate) struct Source<'a> {
    pub doc: &'a mut Document,
    pub viewing: &'a Viewing,
    pub offscreen: Option<Arc<Mutex<OffscreenRenderer>>>,
    pub refiner: Option<RefineWith>,
}

/// The export window's settings (kept between exports).
pub struct ExportSettings {
    pub open: bool,
    pub width: u32,
    pub height: u32,
    pub path: CameraPath,
    pub fps: f32,
    pub gif: bool,
    pub mp4: bool,
}

impl Default for ExportSettings {
    fn default() -> Self {
        Self {
            open: false,
            width: 1024,
            height: 1024,
            path: CameraPath::Fixed,
            fps: 30.0,
            gif: true,
            mp4: true,
        }
    }
}

/// Everything a worker needs to draw the avatar as the viewport does.
struct Shot {
    offscreen: Arc<Mutex<OffscreenRenderer>>,
    avatar: AvatarRef,
    outside: bool,
    background: [f32; 3],
    /// The avatar's refiner, when the view refines: the view's, loaded here unless the view
    /// has already.
    refiner: Option<RefineWith>,
}

impl Shot {
    fn draw(&self, pose: &PoseRef, camera: &Camera) -> Result<image::RgbImage, String> {
        let mut offscreen = self.offscreen.lock().unwrap_or_else(|e| e.into_inner());
        let image = match &self.refiner {
            Some(with) => offscreen.refine_avatar(
                &mut with.refiner.lock().unwrap_or_else(|e| e.into_inner()),
                (&with.path, with.on),
                &self.avatar,
                pose,
                self.outside,
                camera,
            )?,
            None => offscreen
                .render_avatar(&self.avatar, pose, self.outside, camera)
                .map_err(|e| e.to_string())?,
        };
        Ok(image.over(self.background))
    }
}

impl Drop for Shot {
    /// The export is over: its copy of the avatar leaves the GPU.
    fn drop(&mut self) {
        let mut offscreen = self.offscreen.lock().unwrap_or_else(|e| e.into_inner());
        offscreen.release();
    }
}

/// The motion and the hand-set pose a sequence is posed from, per frame.
struct Posing {
    model: Arc<AnyBody>,
    base: BodyPose,
    controls: PoseControls,
    motion: Option<(Arc<Tracking>, Retarget)>,
}

impl Posing {
    fn at(&self, time: f64) -> Result<PoseRef, String> {
        let mut pose = self.base.clone();
        if let Some((tracking, retarget)) = &self.motion {
            retarget.sample(tracking, time, &mut pose);
        }
        self.controls.apply(&mut pose);
        let mut posed = PosedBody::default();
        self.model
            .pose(&pose, &mut posed)
            .map_err(|e| e.to_string())?;
        Ok(PoseRef {
            id: next_id(),
            posed: Arc::new(posed),
        })
    }
}

/// The avatar on screen, ready to be drawn off screen; or why there is none.
fn shot(src: &mut Source) -> Result<Shot, String> {
    let offscreen = src.offscreen.clone().ok_or("no GPU device for exports")?;
    let (Some(avatar), Some(body), View::Avatar) =
        (&src.doc.avatar, &mut src.doc.body, src.viewing.view)
    else {
        return Err("exports draw the avatar: show one first".into());
    };
    Ok(Shot {
        offscreen,
        avatar: avatar.reference(body),
        outside: avatar.show_outside,
        background: src.viewing.background,
        refiner: src.refiner.take(),
    })
}

/// Starts `export` with `settings` from `src`, or says why it cannot.
pub(crate) fn run(
    export: Export,
    settings: &ExportSettings,
    mut src: Source,
) -> Result<Started, String> {
    match export {
        Export::Png(out) => png(out, settings, &mut src),
        Export::Sequence(dir) => sequence(dir, settings, &mut src),
        Export::Ply(out) => posed_ply(&out, src.doc).map(Started::Wrote),
        Export::Mesh(out) => posed_mesh(&out, src.doc, src.viewing).map(Started::Wrote),
        Export::Animatable(out) => animatable(&out, src.doc).map(Started::Wrote),
    }
}

/// The view at the export size as a PNG (refined when the view refines).
fn png(out: PathBuf, settings: &ExportSettings, src: &mut Source) -> Result<Started, String> {
    let (w, h) = (settings.width, settings.height);
    let camera = src.viewing.camera(src.doc, w, h);
    let shot = shot(src)?;
    let pose = src.doc.body.as_mut().ok_or("no body")?.posed();
    let work = {
        let out = out.clone();
        move |context: &JobContext| {
            context.set_stage(format!("drawing {w}×{h}"));
            let image = shot.draw(&pose, &camera)?;
            guava::render::save_png(&image, &out).map_err(|e| format!("{e:#}"))?;
            Ok(format!("wrote {} ({w}×{h})", out.display()))
        }
    };
    Ok(Started::Job(out, Box::new(work)))
}

/// The timeline as `frame_00000.png`, … in `dir` along the export's camera path (and
/// `sequence.gif`, `sequence.mp4` beside them): each frame posed from the motion with the
/// hand-set groups in place.
fn sequence(dir: PathBuf, settings: &ExportSettings, src: &mut Source) -> Result<Started, String> {
    let s = settings;
    let (w, h, fps, path, gif, mp4) = (s.width, s.height, s.fps, s.path, s.gif, s.mp4);
    let shot = shot(src)?;
    let body = src.doc.body.as_ref().ok_or("no body")?;
    let posing = Posing {
        model: body.model.clone(),
        base: body.pose.clone(),
        controls: body.controls.clone(),
        motion: src.doc.motion.as_ref().map(|m| m.sampler()),
    };
    if path == CameraPath::Tracked && src.doc.motion.as_ref().and_then(|m| m.camera()).is_none() {
        return Err("the tracked camera path needs a motion with cameras".into());
    }
    if path == CameraPath::Keys && src.viewing.camera_keys.is_empty() {
        return Err("the keyed camera path has no keys (Camera > Camera path)".into());
    }
    let times = match &posing.motion {
        Some((tracking, _)) => sequence::frame_times(tracking.duration(), fps),
        None => vec![0.0; (2.0 * fps) as usize],
    };
    let fixed = src.viewing.camera(src.doc, w, h);
    let orbit = src.viewing.orbit;
    let keys = src.viewing.camera_keys.clone();
    let tracking = posing.motion.as_ref().map(|(t, _)| t.clone());
    let folder = dir.clone();
    let work = move |context: &JobContext| {
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let n = times.len();
        let mut written = Vec::with_capacity(n);
        for (i, &time) in times.iter().enumerate() {
            if context.cancelled() {
                return Err(format!(
                    "{}: cancelled after {i} of {n} frames (those are whole)",
                    dir.display()
                ));
            }
            context.set_stage(format!("frame {}/{n}", i + 1));
            let camera = match path {
                CameraPath::Fixed => fixed,
                CameraPath::Turntable => OrbitCamera {
                    yaw_rad: orbit.yaw_rad + std::f32::consts::TAU * i as f32 / n as f32,
                    ..orbit
                }
                .camera(w, h),
                CameraPath::Tracked => tracking
                    .as_ref()
                    .and_then(|t| guava::tracking::camera_at(t, time))
                    .map(|(w2c, f)| Camera::guava_in_viewport(w2c, f, w, h))
                    .ok_or("the motion has no camera at this time")?,
                CameraPath::Keys => keys.at(time).ok_or("no camera keys")?.camera(w, h),
            };
            let image = shot.draw(&posing.at(time)?, &camera)?;
            let file = sequence::frame_path(&dir, i);
            guava::render::save_png(&image, &file).map_err(|e| format!("{e:#}"))?;
            written.push(file);
        }
        if gif {
            context.set_stage("writing the GIF");
            sequence::write_gif(&written, fps, &dir.join("sequence.gif"))
                .map_err(|e| format!("{e:#}"))?;
        }
        if mp4 {
            context.set_stage("writing the MP4");
            sequence::write_mp4(&written, fps, &dir.join("sequence.mp4"))
                .map_err(|e| format!("{e:#}"))?;
        }
        Ok(format!(
            "wrote {n} frames ({w}×{h}, {fps} fps) to {}",
            dir.display()
        ))
    };
    Ok(Started::Job(folder, Box::new(work)))
}

/// The avatar as posed now as a 3DGS PLY (y down, as 3DGS files are).
fn posed_ply(out: &Path, doc: &mut Document) -> Result<String, String> {
    let (Some(avatar), Some(body)) = (&doc.avatar, &mut doc.body) else {
        return Err("no avatar to export".into());
    };
    let posed = body.posed();
    let mut cloud = GaussianCloud::new(avatar.avatar.channels);
    guava::avatar::Rig::with_hands(avatar.hands(body))
        .animate(
            &avatar.avatar,
            &posed.posed,
            body.model.as_ref(),
            &mut cloud,
        )
        .map_err(|e| e.to_string())?;
    cloud.rotate(glam::Quat::from_rotation_x(std::f32::consts::PI));
    guava::gaussians::ply::write(out, &cloud).map_err(|e| e.to_string())?;
    Ok(format!(
        "wrote {} ({} Gaussians)",
        out.display(),
        cloud.len()
    ))
}

/// The body as posed now as a binary glTF mesh.
fn posed_mesh(out: &Path, doc: &mut Document, viewing: &Viewing) -> Result<String, String> {
    let Some(body) = &mut doc.body else {
        return Err("no body to export".into());
    };
    // The mesh view's posed positions and normals (made once per pose, shared).
    let mesh = body.frame(viewing.background);
    guava::body::mesh_export::write_glb(out, &mesh.positions, &mesh.normals, &mesh.triangles)
        .map_err(|e| format!("{}: {e}", out.display()))?;
    Ok(format!(
        "wrote {} ({} vertices)",
        out.display(),
        mesh.positions.len()
    ))
}

/// The avatar as a rigged glTF other tools animate (`guava export`): the skinned body with its
/// texture and expression targets, its splats bound to the skeleton, and the timeline's motion
/// as the animation.
fn animatable(out: &Path, doc: &Document) -> Result<String, String> {
    let Some(avatar) = &doc.avatar else {
        return Err("no avatar to export".into());
    };
    let Some(model) = doc.body.as_ref().and_then(|b| b.model.template()) else {
        return Err("the animatable export takes avatars of the default body (GUAVA mode's EHM body is not exported yet)".into());
    };
    let tracking = doc.motion.as_ref().map(|m| m.sampler().0);
    let written =
        guava::export::export(&avatar.avatar, model, tracking.as_deref(), out, &mut |_| {
            true
        })
        .map_err(|e| format!("{}: {e}", out.display()))?;
    Ok(format!(
        "wrote {} ({} joints, {} morph targets, {} splats, {} animation frames)",
        out.display(),
        written.joints,
        written.morph_targets,
        written.splats,
        written.frames
    ))
}

impl ExportSettings {
    /// The export window: size, camera path and rate, and what to write; the export the user
    /// asked for, once its file or folder is picked (`stem`: the file name offered).
    pub(crate) fn window(&mut self, ctx: &egui::Context, stem: &str) -> Option<Export> {
        let mut open = self.open;
        let mut action = None;
        egui::Window::new("Export")
            .open(&mut open)
            .resizable(false)
            .show(ctx, |ui| {
                ui.horizontal(|ui| {
                    ui.label("size");
                    ui.add(egui::DragValue::new(&mut self.width).range(16..=8192));
                    ui.label("×");
                    ui.add(egui::DragValue::new(&mut self.height).range(16..=8192));
                });
                ui.horizontal(|ui| {
                    ui.label("camera path");
                    ui.selectable_value(&mut self.path, CameraPath::Fixed, "fixed");
                    ui.selectable_value(&mut self.path, CameraPath::Turntable, "turntable");
                    ui.selectable_value(&mut self.path, CameraPath::Tracked, "tracked");
                    ui.selectable_value(&mut self.path, CameraPath::Keys, "keys");
                });
                ui.horizontal(|ui| {
                    ui.add(egui::DragValue::new(&mut self.fps).range(1.0..=120.0));
                    ui.label("fps");
                    ui.checkbox(&mut self.gif, "and an animated GIF");
                    ui.checkbox(&mut self.mp4, "and an MP4 (H.264)");
                });
                ui.label(
                    "The avatar as on screen (refined when the view refines); sequences follow \
                     the timeline with the hand-set groups in place.",
                );
                ui.horizontal_wrapped(|ui| {
                    for (label, a) in [
                        ("View as PNG…", Action::Png),
                        ("Sequence…", Action::Sequence),
                        ("Posed avatar as PLY…", Action::Ply),
                        ("Posed mesh as glTF…", Action::Mesh),
                        ("Animatable avatar (glTF)…", Action::Animatable),
                    ] {
                        if ui.button(label).clicked() {
                            action = Some(a);
                        }
                    }
                });
            });
        self.open = open;
        let save = |ext: &str, name: &str| {
            rfd::FileDialog::new()
                .add_filter(name, &[ext])
                .set_file_name(format!("{stem}.{ext}"))
                .save_file()
        };
        match action? {
            Action::Png => save("png", "PNG").map(Export::Png),
            Action::Sequence => rfd::FileDialog::new().pick_folder().map(Export::Sequence),
            Action::Ply => save("ply", "3DGS PLY").map(Export::Ply),
            Action::Mesh => save("glb", "glTF").map(Export::Mesh),
            Action::Animatable => save("glb", "glTF").map(Export::Animatable),
        }
    }
}

#[derive(Clone, Copy)]
enum Action {
    Png,
    Sequence,
    Ply,
    Mesh,
    Animatable,
}
