//! `guava render`: a splat file or an avatar to a PNG, or with `--sequence` to a numbered PNG
//! sequence (and an animated GIF) along a camera path: fixed, turntable, or the motion's tracked
//! camera. Every frame is posed, splatted (and refined with `--refine`) and written atomically,
//! so an interrupted run leaves only whole frames.

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, Result};
use guava::avatar::{Avatar, HandsInView, Rig};
use guava::body::{AnyBody, BodyModel, BodyPose, EhmModel, Posable, PosedBody};
use guava::camera::Camera;
use guava::gaussians::GaussianCloud;
use guava::gpu::GpuContext;
use guava::refine::{Refiner, RefinerOn};
use guava::render::{HeadlessRenderer, sequence};
use guava::tracking::{Retarget, Tracking};

use crate::args;

#[derive(clap::Args)]
pub struct RenderArgs {
    /// A splat file: 3DGS PLY (standard or PlayCanvas's compressed layout) or antimatter15's .splat
    #[arg(long, required_unless_present = "avatar", conflicts_with = "avatar")]
    ply: Option<PathBuf>,
    /// An avatar file (.guava), posed on the default body.
    #[arg(long)]
    avatar: Option<PathBuf>,
    /// With --avatar: the EHM body (tools/convert_ehm.py) a GUAVA-mode avatar is bound to;
    /// without it, avatars are posed on the default body.
    #[arg(long, requires = "avatar")]
    ehm: Option<PathBuf>,
    /// With --avatar: pose it from this motion (tracking .json, ARKit .csv, SMPL-X .npz) at --time.
    #[arg(long, requires = "avatar")]
    motion: Option<PathBuf>,
    #[arg(long, default_value_t = 0.0, requires = "motion", value_parser = args::seconds)]
    time: f64,
    /// With --avatar: pose it as its photo shows it (the view it keeps).
    #[arg(long, requires = "avatar", conflicts_with = "motion")]
    source_pose: bool,
    /// With --motion or --source-pose: view through the motion's tracked camera or the
    /// photo's camera (512², as GUAVA renders). Same as --camera-path tracked.
    #[arg(long)]
    tracked_camera: bool,
    /// Run the avatar's refiner on the splat image: the default refiner for default-mode
    /// avatars, GUAVA's (from --guava-models) for GUAVA-mode ones.
    #[arg(long, requires = "avatar")]
    refine: bool,
    /// With --refine: GUAVA's networks folder (tools/export_guava_onnx.py), whose refiner a
    /// GUAVA-mode avatar is refined by.
    #[arg(long, requires = "refine")]
    guava_models: Option<PathBuf>,
    /// With --refine: where the refiner runs. auto: our WGSL passes on a hardware GPU, ONNX
    /// Runtime on the CPU with a software adapter (lavapipe) or a model the passes do not run.
    #[arg(long, value_enum, default_value = "auto", requires = "refine")]
    refiner_on: RefinerOnArg,
    /// The PNG to write (one frame).
    #[arg(long, required_unless_present = "sequence")]
    out: Option<PathBuf>,
    /// Write a frame sequence into this folder instead (frame_00000.png, …): the whole motion
    /// at --fps, or --frames frames of a turntable.
    #[arg(long, conflicts_with = "out")]
    sequence: Option<PathBuf>,
    /// How the camera moves over the sequence.
    #[arg(long, value_enum, default_value_t = CameraPath::Fixed)]
    camera_path: CameraPath,
    /// Frames per second of the sequence (default: the motion's own).
    #[arg(long, requires = "sequence", value_parser = args::frame_rate)]
    fps: Option<f32>,
    /// Frames of a sequence without a motion (a turntable of a still pose); default 60.
    #[arg(long, requires = "sequence", value_parser = args::frame_count)]
    frames: Option<usize>,
    /// With --sequence: also write the frames as one animated GIF (256 colours per frame).
    #[arg(long, requires = "sequence")]
    gif: Option<PathBuf>,
    /// With --sequence: also write the frames as an H.264 MP4 video.
    #[arg(long, requires = "sequence")]
    mp4: Option<PathBuf>,
    /// Image size in pixels (1 to 8192).
    #[arg(long, default_value_t = 512, value_parser = args::image_side)]
    width: u32,
    #[arg(long, default_value_t = 512, value_parser = args::image_side)]
    height: u32,
    /// Vertical field of view in degrees (above 0, below 180).
    #[arg(long, default_value_t = 50.0, value_parser = args::field_of_view)]
    fov: f32,
    /// Orbit angles in degrees around the cloud's centre (a turntable starts at --yaw).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = args::angle)]
    yaw: f32,
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = args::angle)]
    pitch: f32,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CameraPath {
    /// The orbit camera at --yaw and --pitch, framed on the first frame.
    Fixed,
    /// Once around the subject over the sequence, starting at --yaw.
    Turntable,
    /// The motion's tracked camera (or the photo's with --source-pose).
    Tracked,
}

/// What is rendered: a splat file as it is, or an avatar posed per frame.
enum Subject {
    Splats(GaussianCloud),
    Avatar(Box<Posed>),
}

/// An avatar, its body and how it is posed.
struct Posed {
    avatar: Avatar,
    body: AnyBody,
    posing: Posing,
}

/// How an avatar is posed.
enum Posing {
    Rest,
    /// A motion, retargeted to the body once.
    Motion(Box<Tracking>, Retarget),
    /// As its photo shows it.
    Source,
}

impl Subject {
    fn load(args: &RenderArgs) -> Result<(Self, String)> {
        match (&args.ply, &args.avatar) {
            (Some(ply), _) => Ok((
                Subject::Splats(guava::gaussians::read_file(ply)?),
                ply.display().to_string(),
            )),
            (None, Some(path)) => {
                let avatar = Avatar::load(path)?;
                let body = match &args.ehm {
                    Some(ehm) => {
                        let mut body = EhmModel::load(ehm)?;
                        avatar.apply_ehm_identity(&mut body);
                        AnyBody::Ehm(Box::new(body))
                    }
                    None => AnyBody::Template(std::sync::Arc::new(BodyModel::default_body()?)),
                };
                let with_path = |e: String| anyhow::anyhow!("{}: {e}", path.display());
                avatar.check_body(&body).map_err(with_path)?;
                let posing = match (&args.motion, args.source_pose) {
                    (Some(m), _) => {
                        let t = guava::tracking::import::open_motion(m)?.tracking;
                        let retarget = Retarget::new(&t, &body);
                        Posing::Motion(Box::new(t), retarget)
                    }
                    (None, true) if avatar.source_view.is_none() => {
                        return Err(with_path(guava::eval::EvalError::NoSourceView.to_string()));
                    }
                    (None, true) => Posing::Source,
                    (None, false) => Posing::Rest,
                };
                let subject = Subject::Avatar(Box::new(Posed {
                    avatar,
                    body,
                    posing,
                }));
                Ok((subject, path.display().to_string()))
            }
            (None, None) => anyhow::bail!("give --ply or --avatar"),
        }
    }

    /// The motion's length (seconds) and frame rate, if a motion drives the subject.
    fn motion(&self) -> Option<(f64, f32)> {
        match self {
            Subject::Avatar(posed) => match &posed.posing {
                Posing::Motion(t, _) => Some((t.duration(), t.fps)),
                _ => None,
            },
            Subject::Splats(_) => None,
        }
    }

    /// The Gaussians at `time`, with the camera that goes with the pose: the motion's tracked
    /// camera at that time (if it has one), or the photo's.
    fn at(&self, time: f64, rig: &mut Rig) -> Result<(Cow<'_, GaussianCloud>, Option<Camera>)> {
        let posed = match self {
            Subject::Splats(cloud) => return Ok((Cow::Borrowed(cloud), None)),
            Subject::Avatar(p) => posed_avatar(&p.avatar, &p.body, &p.posing, time, rig),
        };
        posed.map(|(cloud, camera)| (Cow::Owned(cloud), camera))
    }
}

fn posed_avatar(
    avatar: &Avatar,
    body: &impl Posable,
    posing: &Posing,
    time: f64,
    rig: &mut Rig,
) -> Result<(GaussianCloud, Option<Camera>)> {
    // A motion starts from the photo's pose: joints it does not drive stay as the photo shows.
    let mut pose = match posing {
        Posing::Rest => BodyPose::rest(body),
        _ => avatar.base_pose(body),
    };
    let camera = match posing {
        Posing::Rest => None,
        Posing::Motion(t, retarget) => {
            retarget.sample(t, time, &mut pose);
            guava::tracking::camera_at(t, time)
                .map(|(w2c, invtanfov)| Camera::guava(w2c, guava::photo::SOURCE_SIZE, invtanfov))
        }
        Posing::Source => {
            let view = avatar.source_view.as_ref().expect("checked at load");
            pose = view.pose.clone();
            Some(view.camera)
        }
    };
    avatar.apply_identity(body, &mut pose);
    let mut posed = PosedBody::default();
    body.pose(&pose, &mut posed)?;
    let mut cloud = GaussianCloud::new(avatar.channels);
    rig.animate(avatar, &posed, body, &mut cloud)?;
    Ok((cloud, camera))
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum RefinerOnArg {
    Auto,
    Cpu,
    Gpu,
}

pub fn run(args: RenderArgs) -> Result<()> {
    let (subject, name) = Subject::load(&args)?;
    let renderer = HeadlessRenderer::new(GpuContext::headless()?);
    let refiner = match (&subject, args.refine) {
        (Subject::Avatar(posed), true) => {
            let avatar = &posed.avatar;
            let path = guava::refine::refiner_for(avatar.kind, args.guava_models.as_deref())
                .map_err(|e| anyhow::anyhow!("{name}: {e} (--guava-models)"))?;
            let on = match args.refiner_on {
                RefinerOnArg::Auto => RefinerOn::Auto,
                RefinerOnArg::Cpu => RefinerOn::Cpu,
                RefinerOnArg::Gpu => RefinerOn::Gpu,
            };
            Some(Refiner::load_on(on, &renderer.gpu, &path)?)
        }
        _ => None,
    };
    let path = match (args.tracked_camera, args.camera_path) {
        (true, _) => CameraPath::Tracked,
        (false, path) => path,
    };
    // The hands the photo did not show are drawn where it looked, as the viewer draws them.
    let rig = match &subject {
        Subject::Avatar(posed) => {
            Rig::with_hands(HandsInView::new(&posed.avatar, &posed.body).map(Arc::new))
        }
        Subject::Splats(_) => Rig::default(),
    };
    let mut frames = Frames {
        subject,
        name,
        path,
        rig,
        renderer,
        refiner,
        framed_on: None,
        args: &args,
    };
    match &args.sequence {
        None => {
            let out = args
                .out
                .as_deref()
                .expect("clap requires --out or --sequence");
            let yaw = args.yaw.to_radians();
            let (image, stats) = frames.render(args.time, yaw)?;
            guava::render::save_png(&image, out)?;
            println!(
                "{}: {} Gaussians, {} drawn, {} culled ({} tile pairs) → {} [{}]",
                frames.name,
                stats.input,
                stats.visible,
                stats.culled(),
                stats.tile_pairs,
                out.display(),
                frames.renderer.gpu.adapter_label()
            );
            if let Some(refiner) = &frames.refiner {
                println!(
                    "refined by {} on {}",
                    refiner.description,
                    refiner.engine_name()
                );
            }
            Ok(())
        }
        Some(dir) => frames.sequence(dir),
    }
}

/// Renders the subject's frames along the camera path.
struct Frames<'a> {
    subject: Subject,
    name: String,
    path: CameraPath,
    rig: Rig,
    renderer: HeadlessRenderer,
    refiner: Option<Refiner>,
    /// The first frame's Gaussians: the orbit frames them for the whole sequence, so the camera
    /// does not follow the motion around.
    framed_on: Option<GaussianCloud>,
    args: &'a RenderArgs,
}

impl Frames<'_> {
    fn render(
        &mut self,
        time: f64,
        yaw: f32,
    ) -> Result<(image::RgbImage, guava::render::RenderStats)> {
        let (cloud, tracked) = self.subject.at(time, &mut self.rig)?;
        let a = self.args;
        let camera = match (self.path, tracked) {
            (CameraPath::Tracked, Some(camera)) => camera,
            (CameraPath::Tracked, None) => anyhow::bail!(
                "--tracked-camera: no camera to look through (give a motion with tracked \
                 cameras, or --source-pose for an avatar that keeps its photo's view)"
            ),
            _ => {
                let framed = self.framed_on.get_or_insert_with(|| cloud.as_ref().clone());
                let is_avatar = matches!(self.subject, Subject::Avatar(_));
                // Avatars stand on a y-up body; splat files use GUAVA's y-down axes.
                let view = guava::camera::orbit_view(
                    framed,
                    a.fov.to_radians(),
                    yaw,
                    a.pitch.to_radians(),
                    is_avatar,
                )
                .with_context(|| format!("{}: no finite Gaussian to frame", self.name))?;
                Camera::from_fov_y(view, a.width, a.height, a.fov.to_radians())
            }
        };
        let background = vec![0.0; cloud.channels];
        let (image, stats) = match &mut self.refiner {
            Some(refiner) => {
                let stats = self.renderer.draw_cloud(&cloud, &camera, &background)?;
                (refiner.refine_drawn(&self.renderer)?, stats)
            }
            None => self.renderer.render(&cloud, &camera, &background)?,
        };
        Ok((image.to_rgb8(), stats))
    }

    /// The whole motion (or a still pose's turntable) as numbered PNGs in `dir`, then the GIF.
    fn sequence(&mut self, dir: &Path) -> Result<()> {
        let a = self.args;
        let (times, fps) = match self.subject.motion() {
            Some((duration, motion_fps)) => {
                let fps = a.fps.unwrap_or(motion_fps);
                (sequence::frame_times(duration, fps), fps)
            }
            None => (vec![a.time; a.frames.unwrap_or(60)], a.fps.unwrap_or(30.0)),
        };
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let n = times.len();
        let started = Instant::now();
        let mut written = Vec::with_capacity(n);
        for (i, &time) in times.iter().enumerate() {
            let turn = match self.path {
                CameraPath::Turntable => std::f32::consts::TAU * i as f32 / n as f32,
                _ => 0.0,
            };
            let (image, _) = self.render(time, a.yaw.to_radians() + turn)?;
            let file = sequence::frame_path(dir, i);
            guava::render::save_png(&image, &file)?;
            written.push(file);
            let per = started.elapsed().as_secs_f64() / (i + 1) as f64;
            eprint!(
                "\r{}: frame {}/{n}, {:.2} s per frame, {:.0} s left   ",
                self.name,
                i + 1,
                per,
                per * (n - i - 1) as f64
            );
        }
        eprintln!();
        println!(
            "{}: {n} frames at {fps} fps → {} [{}]",
            self.name,
            dir.display(),
            self.renderer.gpu.adapter_label()
        );
        if let Some(gif) = &a.gif {
            sequence::write_gif(&written, fps, gif)?;
            println!("{} frames → {}", n, gif.display());
        }
        if let Some(mp4) = &a.mp4 {
            sequence::write_mp4(&written, fps, mp4)?;
            println!("{} frames → {}", n, mp4.display());
        }
        Ok(())
    }
}
