//! `guava bench frame`: what a frame of the viewer costs for the default avatar (the demo
//! portrait's default reconstruction, played by the demo motion), pose → pixels.
//!
//! 1. **Frame path, side by side in one run**: posing the body on the CPU, then either the old
//!    path (every Gaussian rigged on the CPU, re-packed and uploaded) or the GPU-resident avatar
//!    (the posed vertices go up, the rig pass poses the Gaussians), then the splatting pass.
//! 2. **Interaction**: a replay of what a user does — orbiting while the motion plays — through
//!    the viewer's own view renderer, at full resolution and at the reduced ones the viewer uses
//!    while input moves, as frames per second.
//! 3. **Settle → refined**: once the view stops, the time until the refined picture is on the
//!    GPU and the GPU memory held for it, side by side: the refiner as a pass on the view's own
//!    frame, against the path the viewer used before (the frame drawn again on a second
//!    renderer holding its own copy of the avatar, then refined), for each place the refiner
//!    runs.

use std::sync::Arc;
use std::time::Instant;

use super::body::cpu_name;
use super::median;
use guava::avatar::{HandsInView, Rig};
use guava::body::{BodyModel, BodyPose, PosedBody};
use guava::camera::{Camera, orbit_y_up};
use guava::gaussians::GaussianCloud;
use guava::gpu::GpuContext;
use guava::pipeline::{Mode, Photo, Pipeline, Tracked};
use guava::refine::{DEFAULT_REFINER, Refiner, RefinerOn, SharedRefiner};
use guava::render::{GpuAvatar, HeadlessRenderer};
use guava::tracking::{Retarget, demo_motion};
use guava::view::{
    AvatarRef, Content, Display, Frame, Look, PoseRef, RefineWith, ViewRenderer, ViewReport,
};

#[derive(clap::Args, Clone, Debug)]
pub struct FrameBenchArgs {
    /// Timed frames per case (after 3 warm-up frames).
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    /// Settles timed per refiner case (after one warm-up).
    #[arg(long, default_value_t = 4)]
    pub settles: usize,
    /// The viewport's size for the interaction replay (the viewer's at 1280×800 is ~770×700).
    #[arg(long, default_value_t = 768)]
    pub width: u32,
    #[arg(long, default_value_t = 704)]
    pub height: u32,
}

pub fn frame(args: &FrameBenchArgs) -> anyhow::Result<()> {
    let body = BodyModel::default_body()?;
    let portrait = std::path::PathBuf::from(guava::DEMO_PORTRAIT);
    let outcome = Pipeline::default().reconstruct(
        Mode::Default(&body),
        Photo::File(&portrait),
        Tracked::beside(&portrait),
        &mut |_| true,
    )?;
    let avatar = Arc::new(outcome.avatar);
    let motion = demo_motion()?;
    let retarget = Retarget::new(&motion, &body);
    let mut pose = BodyPose::rest(&body);
    avatar.apply_identity(&body, &mut pose);
    // Frame k of the demo motion at 30 fps: every frame is a new pose, as while it plays.
    let mut pose_at = |k: usize, posed: &mut PosedBody| -> anyhow::Result<()> {
        retarget.sample(&motion, k as f64 / 30.0 % motion.duration(), &mut pose);
        body.pose(&pose, posed)?;
        Ok(())
    };
    let mut renderer = HeadlessRenderer::new(GpuContext::headless()?);
    let adapter = renderer.gpu.adapter_label();
    println!(
        "the demo portrait's default avatar ({} Gaussians, {} channels) played by the demo motion; \
         {adapter}; CPU {}; medians of {} frames",
        avatar.len(),
        avatar.channels,
        cpu_name(),
        args.frames
    );
    let camera = outcome.view.camera;
    let background = vec![0.0; avatar.channels];

    println!("\npose → pixels at 512² through the photo's camera, ms per frame:");
    println!(
        "{:<44} {:>8} {:>10} {:>8} {:>8}",
        "path", "pose", "rig+upload", "splat", "frame"
    );
    let mut posed = PosedBody::default();
    let mut cloud = GaussianCloud::new(avatar.channels);
    // The hands the photo did not show, as the viewer decides them each frame.
    let hands = HandsInView::new(&avatar, &body).map(Arc::new);
    let mut rig = Rig::with_hands(hands.clone());
    let mut gpu_avatar = GpuAvatar::new(
        &renderer.gpu.device,
        renderer.pipelines.clone(),
        &avatar,
        &body.triangles,
        Some(&body.weld),
    );
    gpu_avatar.set_hands(hands.clone());
    let mut rows = Vec::new();
    for gpu in [false, true] {
        let mut times: [Vec<f64>; 4] = Default::default();
        gpu_avatar.detach();
        for k in 0..args.frames + 3 {
            let t0 = Instant::now();
            pose_at(k, &mut posed)?;
            let t1 = Instant::now();
            if gpu {
                renderer.pose_avatar(&mut gpu_avatar, &posed)?;
                // Waited for, so the rig pass is timed apart from the splatting.
                guava::render::wait(&renderer.gpu.device);
            } else {
                rig.animate(&avatar, &posed, &body, &mut cloud)?;
                let gpu = &renderer.gpu;
                renderer.splatter.upload(&gpu.device, &gpu.queue, &cloud)?;
            }
            let t2 = Instant::now();
            renderer.draw(&camera, &background);
            let t3 = Instant::now();
            if k >= 3 {
                for (v, d) in times.iter_mut().zip([t1 - t0, t2 - t1, t3 - t2, t3 - t0]) {
                    v.push(d.as_secs_f64() * 1e3);
                }
            }
        }
        let name = if gpu {
            "GPU-resident avatar: pose up, rig pass"
        } else {
            "before: rig on the CPU, all Gaussians up"
        };
        let [p, r, s, f] = times.map(median);
        println!("{name:<44} {p:>8.1} {r:>10.1} {s:>8.1} {f:>8.1}");
        rows.push(f);
    }
    println!("ratio (GPU-resident / before): {:.2}", rows[1] / rows[0]);

    interaction(args, &renderer.gpu, &avatar, &body, &mut pose_at)?;
    settle_to_refined(args, &renderer.gpu, &avatar, &body)
}

/// The viewer's view renderer replaying an orbit while the motion plays, at each resolution
/// scale the viewer offers while input moves.
fn interaction(
    args: &FrameBenchArgs,
    gpu: &GpuContext,
    avatar: &Arc<guava::avatar::Avatar>,
    body: &BodyModel,
    pose_at: &mut dyn FnMut(usize, &mut PosedBody) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let (device, queue) = (&gpu.device, &gpu.queue);
    let mut view = ViewRenderer::new(
        device,
        queue,
        &gpu.adapter.get_info(),
        wgpu::TextureFormat::Rgba8UnormSrgb,
    );
    let mut report = ViewReport::default();
    let (triangles, weld) = (
        Arc::new(body.triangles.clone()),
        Arc::new(body.weld.clone()),
    );
    let hands = HandsInView::new(avatar, body).map(Arc::new);
    let mut posed = PosedBody::default();
    pose_at(0, &mut posed)?;
    let (lo, hi) = posed
        .vertices
        .iter()
        .fold((glam::Vec3::MAX, glam::Vec3::MIN), |(l, h), v| {
            (l.min(*v), h.max(*v))
        });
    let target = 0.5 * (lo + hi);
    let fov = 50f32.to_radians();
    let distance = 0.5 * (hi - lo).length() / (0.5 * fov).sin();
    println!(
        "\ninteraction replay at {}×{} (orbiting 3° a frame while the motion plays), the \
         viewer's view renderer:",
        args.width, args.height
    );
    println!(
        "{:<34} {:>12} {:>10} {:>10} {:>8}",
        "while interacting", "splatted at", "Gaussians", "ms/frame", "fps"
    );
    let cases = [
        (1.0, false, "full quality"),
        (0.5, false, "½ resolution"),
        (1.0 / 3.0, false, "⅓ resolution"),
        (0.5, true, "½ + coarse (CPU default)"),
        (1.0 / 3.0, true, "⅓ + coarse"),
        (0.25, true, "¼ + coarse"),
    ];
    for (scale, preview, name) in cases {
        let mut times = Vec::new();
        for k in 0..args.frames + 3 {
            let t0 = Instant::now();
            pose_at(k, &mut posed)?;
            let yaw = (3.0 * k as f32).to_radians();
            let frame = Frame {
                content: Content::Avatar {
                    avatar: AvatarRef {
                        id: 1,
                        avatar: avatar.clone(),
                        triangles: triangles.clone(),
                        weld: Some(weld.clone()),
                        hands: hands.clone(),
                    },
                    pose: PoseRef {
                        id: k as u64 + 1,
                        posed: Arc::new(posed.clone()),
                    },
                    look: Look {
                        background: vec![0.0; avatar.channels],
                        display: Display::default(),
                    },
                    outside: false,
                },
                camera: Camera::from_fov_y(
                    orbit_y_up(target, distance, yaw, 0.0),
                    args.width,
                    args.height,
                    fov,
                ),
                scale,
                preview,
                pane: 0,
                refine: None,
            };
            queue.submit(view.prepare(device, queue, &frame, &mut report));
            guava::render::wait(device);
            if k >= 3 {
                times.push(t0.elapsed().as_secs_f64() * 1e3);
            }
        }
        let ms = median(times);
        let [w, h] = report.rendered_size;
        let count = if preview {
            avatar.preview().len()
        } else {
            avatar.len()
        };
        println!(
            "{name:<34} {:>12} {count:>10} {ms:>10.1} {:>8.1}",
            format!("{w}×{h}"),
            1e3 / ms
        );
    }
    Ok(())
}

/// The time from the view settling to its refined picture on the GPU, and the GPU memory held
/// then, with the refiner as a pass on the view's frame and with the viewer's old path (the
/// frame drawn again on a second renderer with its own pipelines and copy of the avatar, then
/// refined), side by side for each place the refiner runs.
fn settle_to_refined(
    args: &FrameBenchArgs,
    gpu: &GpuContext,
    avatar: &Arc<guava::avatar::Avatar>,
    body: &BodyModel,
) -> anyhow::Result<()> {
    let (device, queue) = (&gpu.device, &gpu.queue);
    let format = wgpu::TextureFormat::Rgba8UnormSrgb;
    let mut view = ViewRenderer::new(device, queue, &gpu.adapter.get_info(), format);
    let mut report = ViewReport::default();
    let mut pose = BodyPose::rest(body);
    avatar.apply_identity(body, &mut pose);
    let mut posed = PosedBody::default();
    body.pose(&pose, &mut posed)?;
    let posed = Arc::new(posed);
    let camera_at = |yaw_deg: f32| {
        let base = guava::synthetic::upper_body_camera(body, yaw_deg.to_radians());
        base.scaled(args.width as f32 / base.width as f32)
    };
    let frame = |yaw_deg: f32, refine: Option<RefineWith>| Frame {
        content: Content::Avatar {
            avatar: AvatarRef {
                id: 1,
                avatar: avatar.clone(),
                triangles: Arc::new(body.triangles.clone()),
                weld: Some(Arc::new(body.weld.clone())),
                hands: HandsInView::new(avatar, body).map(Arc::new),
            },
            pose: PoseRef {
                id: 1,
                posed: posed.clone(),
            },
            look: Look {
                background: vec![0.0; avatar.channels],
                display: Display::default(),
            },
            outside: false,
        },
        camera: camera_at(yaw_deg),
        scale: 1.0,
        preview: false,
        pane: 0,
        refine,
    };
    // The old path's second renderer, built as the viewer built it (its own pipelines).
    let mut second = HeadlessRenderer::new(gpu.clone());
    let mut second_avatar = GpuAvatar::new(
        device,
        second.pipelines.clone(),
        avatar,
        &body.triangles,
        Some(&body.weld),
    );
    let black = vec![0.0; avatar.channels];
    let camera = camera_at(0.0);
    println!(
        "\nsettle → refined picture at {}×{} (a new view each settle), ms, medians of {}:",
        camera.width, camera.height, args.settles
    );
    println!(
        "{:<22} {:>14} {:>14} {:>8} {:>16} {:>16}",
        "refiner on", "view's frame", "drawn again", "ratio", "GPU MiB (view)", "GPU MiB (again)"
    );
    let mib = |b: u64| b as f64 / f64::from(1 << 20);
    for on in [RefinerOn::Cpu, RefinerOn::Gpu] {
        let path = std::path::Path::new(DEFAULT_REFINER);
        let shared = SharedRefiner::default();
        *shared.lock().unwrap_or_else(|e| e.into_inner()) = Some(Refiner::load_on(on, gpu, path)?);
        let with = RefineWith {
            refiner: shared.clone(),
            path: path.to_path_buf(),
            on,
            behind: false,
            wake: None,
        };
        let (mut on_view, mut again) = (Vec::new(), Vec::new());
        for k in 0..=args.settles {
            let yaw = 10.0 * k as f32 + if on == RefinerOn::Gpu { 5.0 } else { 0.0 };
            // The refiner as a pass on the view's frame: prepare until the picture is there.
            let t0 = Instant::now();
            let before = report.refine.frames;
            let settled = frame(yaw, Some(with.clone()));
            while report.refine.frames == before {
                queue.submit(view.prepare(device, queue, &settled, &mut report));
                guava::render::wait(device);
                if let Some(e) = report.refine.error.take() {
                    anyhow::bail!("refining on the view: {e}");
                }
                // As a UI waits for its next frame (not spinning beside the CPU refiner).
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
            let t1 = Instant::now();
            // Before: the view's raw frame, then the same frame drawn again and refined.
            let raw = frame(yaw + 2.5, None);
            queue.submit(view.prepare(device, queue, &raw, &mut report));
            guava::render::wait(device);
            let mut guard = shared.lock().unwrap_or_else(|e| e.into_inner());
            let refiner = guard.as_mut().expect("loaded above");
            second.draw_avatar(&mut second_avatar, &posed, &raw.camera, &black)?;
            refiner.refine_drawn(&second)?;
            let t2 = Instant::now();
            if k > 0 {
                on_view.push((t1 - t0).as_secs_f64() * 1e3);
                again.push((t2 - t1).as_secs_f64() * 1e3);
            }
        }
        // Held for a settled refined frame: the view's splatter and avatar (and its picture);
        // before, also the second renderer's splatter and avatar (the picture went to egui).
        let picture = u64::from(camera.width) * u64::from(camera.height) * 16;
        let view_bytes = view.memory().total() + view.avatar_bytes() + picture;
        let again_bytes = view.memory().total()
            + view.avatar_bytes()
            + second.splatter.memory().total()
            + second_avatar.gpu_bytes();
        let (a, b) = (median(on_view), median(again));
        let engine = shared
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_ref()
            .map_or(String::new(), |r| r.engine_name().to_string());
        println!(
            "{engine:<22} {a:>14.1} {b:>14.1} {:>8.2} {:>16.1} {:>16.1}",
            a / b,
            mib(view_bytes),
            mib(again_bytes)
        );
    }
    println!(
        "avatar uploads in the view: {} (all Gaussians; the coarse stand-in adds one once the \
         user drags); the old path added one more on its second renderer",
        report.avatar_uploads
    );
    Ok(())
}
