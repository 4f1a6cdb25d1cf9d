//! What the viewer writes out, each as a job (progress in the status bar, Cancel) writing
//! atomically: the view as a PNG at any size, refined as on screen; the timeline as a PNG
//! sequence (and an animated GIF) along a camera path (fixed, turntable, tracked); the posed
//! avatar as a 3DGS PLY other splat viewers open; the posed body as glTF.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use guava::body::{BodyPose, Posable, PosedBody};
use guava::camera::Camera;
use guava::gaussians::GaussianCloud;
use guava::render::sequence;
use guava::tracking::{Retarget, Tracking};
use guava::view::{AvatarRef, PoseRef, RefineWith};

use crate::app::{GuavaApp, View};
use crate::ids::next_id;
use crate::jobs::{Job, JobContext, Loaded};
use crate::offscreen::OffscreenRenderer;
use crate::orbit::OrbitCamera;
use crate::pose_controls::PoseControls;
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

impl GuavaApp {
    /// The avatar on screen, ready to be drawn off screen; or why there is none.
    fn shot(&mut self) -> Result<Shot, String> {
        let offscreen = self
            .gpu
            .offscreen
            .clone()
            .ok_or("no GPU device for exports")?;
        let (Some(avatar), Some(body), View::Avatar) =
            (&self.doc.avatar, &mut self.doc.body, self.viewing.view)
        else {
            return Err("exports draw the avatar: show one first".into());
        };
        let refiner = self
            .refined
            .enabled
            .then(|| {
                let networks = self.doc.networks.as_ref().map(|n| n.dir.as_path());
                guava::refine::refiner_for(avatar.avatar.kind, networks).ok()
            })
            .flatten()
            .map(|path| RefineWith {
                refiner: self.refined.refiner.clone(),
                path,
                on: self.refined.on,
                behind: false,
                wake: None,
            });
        Ok(Shot {
            offscreen,
            avatar: avatar.reference(body),
            outside: avatar.show_outside,
            background: self.viewing.background,
            refiner,
        })
    }

    fn start_export(
        &mut self,
        path: &Path,
        work: impl FnOnce(&JobContext) -> Result<String, String> + Send + 'static,
    ) {
        if self.job.is_some() {
            self.error("another job is running: wait for it or cancel it".into());
            return;
        }
        self.job = Some(Job::spawn(
            path.to_path_buf(),
            "exporting",
            move |context| work(context).map(Loaded::Exported),
        ));
    }

    /// Writes the view at the export size as a PNG (refined when the view refines).
    pub fn export_png(&mut self, out: PathBuf) {
        let (w, h) = (self.export.width, self.export.height);
        let camera = self.view_camera(w, h);
        let shot = match self.shot() {
            Ok(s) => s,
            Err(e) => return self.error(e),
        };
        let pose = self.doc.body.as_mut().expect("shot checked").posed();
        self.start_export(&out.clone(), move |context| {
            context.set_stage(format!("drawing {w}×{h}"));
            let image = shot.draw(&pose, &camera)?;
            guava::render::save_png(&image, &out).map_err(|e| format!("{e:#}"))?;
            Ok(format!("wrote {} ({w}×{h})", out.display()))
        });
    }

    /// Writes the timeline as `frame_00000.png`, … in `dir` along the export's camera path
    /// (and `sequence.gif`, `sequence.mp4` beside them): each frame posed from the motion with
    /// the hand-set groups in place.
    pub fn export_sequence(&mut self, dir: PathBuf) {
        let s = &self.export;
        let (w, h, fps, path, gif, mp4) = (s.width, s.height, s.fps, s.path, s.gif, s.mp4);
        let shot = match self.shot() {
            Ok(s) => s,
            Err(e) => return self.error(e),
        };
        let body = self.doc.body.as_ref().expect("shot checked");
        let posing = Posing {
            model: body.model.clone(),
            base: body.pose.clone(),
            controls: body.controls.clone(),
            motion: self.doc.motion.as_ref().map(|m| m.sampler()),
        };
        if path == CameraPath::Tracked
            && self.doc.motion.as_ref().and_then(|m| m.camera()).is_none()
        {
            return self.error("the tracked camera path needs a motion with cameras".into());
        }
        if path == CameraPath::Keys && self.viewing.camera_keys.is_empty() {
            return self.error("the keyed camera path has no keys (Camera > Camera path)".into());
        }
        let times = match &posing.motion {
            Some((tracking, _)) => sequence::frame_times(tracking.duration(), fps),
            None => vec![0.0; (2.0 * fps) as usize],
        };
        let fixed = self.view_camera(w, h);
        let orbit = self.viewing.orbit;
        let keys = self.viewing.camera_keys.clone();
        let tracking = posing.motion.as_ref().map(|(t, _)| t.clone());
        self.start_export(&dir.clone(), move |context| {
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
        });
    }

    /// Writes the avatar as posed now as a 3DGS PLY (y down, as 3DGS files are).
    pub fn export_posed_ply(&mut self, out: &Path) -> Result<(), String> {
        let (Some(avatar), Some(body)) = (&self.doc.avatar, &mut self.doc.body) else {
            return Err("no avatar to export".into());
        };
        let posed = body.posed();
        let mut cloud = GaussianCloud::new(avatar.avatar.channels);
        guava::avatar::Rig::default()
            .animate(
                &avatar.avatar,
                &posed.posed,
                body.model.as_ref(),
                &mut cloud,
            )
            .map_err(|e| e.to_string())?;
        cloud.rotate(glam::Quat::from_rotation_x(std::f32::consts::PI));
        guava::gaussians::ply::write(out, &cloud).map_err(|e| e.to_string())?;
        self.info(format!(
            "wrote {} ({} Gaussians)",
            out.display(),
            cloud.len()
        ));
        Ok(())
    }

    /// Writes the body as posed now as a binary glTF mesh.
    pub fn export_posed_mesh(&mut self, out: &Path) -> Result<(), String> {
        let Some(body) = &mut self.doc.body else {
            return Err("no body to export".into());
        };
        // The mesh view's posed positions and normals (made once per pose, shared).
        let mesh = body.frame(self.viewing.background);
        guava::body::mesh_export::write_glb(out, &mesh.positions, &mesh.normals, &mesh.triangles)
            .map_err(|e| format!("{}: {e}", out.display()))?;
        self.info(format!(
            "wrote {} ({} vertices)",
            out.display(),
            mesh.positions.len()
        ));
        Ok(())
    }

    /// Writes the avatar as a rigged glTF other tools animate (`guava export`): the skinned body
    /// with its texture and expression targets, its splats bound to the skeleton, and the
    /// timeline's motion as the animation.
    pub fn export_animatable(&mut self, out: &Path) -> Result<(), String> {
        let Some(avatar) = &self.doc.avatar else {
            return Err("no avatar to export".into());
        };
        let Some(model) = self.doc.body.as_ref().and_then(|b| b.model.template()) else {
            return Err("the animatable export takes avatars of the default body (GUAVA mode's EHM body is not exported yet)".into());
        };
        let tracking = self.doc.motion.as_ref().map(|m| m.sampler().0);
        let written =
            guava::export::export(&avatar.avatar, model, tracking.as_deref(), out, &mut |_| {
                true
            })
            .map_err(|e| format!("{}: {e}", out.display()))?;
        self.info(format!(
            "wrote {} ({} joints, {} morph targets, {} splats, {} animation frames)",
            out.display(),
            written.joints,
            written.morph_targets,
            written.splats,
            written.frames
        ));
        Ok(())
    }

    /// The export window: size, camera path and rate, and what to write.
    pub(crate) fn export_ui(&mut self, ctx: &egui::Context) {
        let mut open = self.export.open;
        let mut action = None;
        egui::Window::new("Export")
            .open(&mut open)
            .resizable(false)
            .show(ctx, |ui| {
                let s = &mut self.export;
                ui.horizontal(|ui| {
                    ui.label("size");
                    ui.add(egui::DragValue::new(&mut s.width).range(16..=8192));
                    ui.label("×");
                    ui.add(egui::DragValue::new(&mut s.height).range(16..=8192));
                });
                ui.horizontal(|ui| {
                    ui.label("camera path");
                    ui.selectable_value(&mut s.path, CameraPath::Fixed, "fixed");
                    ui.selectable_value(&mut s.path, CameraPath::Turntable, "turntable");
                    ui.selectable_value(&mut s.path, CameraPath::Tracked, "tracked");
                    ui.selectable_value(&mut s.path, CameraPath::Keys, "keys");
                });
                ui.horizontal(|ui| {
                    ui.add(egui::DragValue::new(&mut s.fps).range(1.0..=120.0));
                    ui.label("fps");
                    ui.checkbox(&mut s.gif, "and an animated GIF");
                    ui.checkbox(&mut s.mp4, "and an MP4 (H.264)");
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
        self.export.open = open;
        let stem = self
            .doc
            .avatar
            .as_ref()
            .and_then(|a| Path::new(&a.avatar.source).file_stem())
            .map_or_else(|| "avatar".into(), |s| s.to_string_lossy().into_owned());
        let save = |ext: &str, name: &str| {
            rfd::FileDialog::new()
                .add_filter(name, &[ext])
                .set_file_name(format!("{stem}.{ext}"))
                .save_file()
        };
        let result = match action {
            None => Ok(()),
            Some(Action::Png) => {
                if let Some(p) = save("png", "PNG") {
                    self.export_png(p);
                }
                Ok(())
            }
            Some(Action::Sequence) => {
                if let Some(dir) = rfd::FileDialog::new().pick_folder() {
                    self.export_sequence(dir);
                }
                Ok(())
            }
            Some(Action::Ply) => {
                save("ply", "3DGS PLY").map_or(Ok(()), |p| self.export_posed_ply(&p))
            }
            Some(Action::Mesh) => {
                save("glb", "glTF").map_or(Ok(()), |p| self.export_posed_mesh(&p))
            }
            Some(Action::Animatable) => {
                save("glb", "glTF").map_or(Ok(()), |p| self.export_animatable(&p))
            }
        };
        if let Err(e) = result {
            self.error(e);
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
