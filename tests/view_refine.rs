//! The refiner as a pass on the view's own frame: what a view renderer presents — the raw splat
//! over a background, the frame refined by ONNX Runtime on the CPU (read back while frames go
//! on) or by our WGSL passes recorded with the frame — is what the off-screen path gives (draw
//! on black, refine, composite over the background), with the avatar uploaded once.

use std::path::Path;
use std::sync::Arc;

use guava::avatar::Avatar;
use guava::body::{BodyModel, BodyPose, Posable, PosedBody};
use guava::gpu::GpuContext;
use guava::pipeline::{Photo, Pipeline, Tracked};
use guava::refine::{DEFAULT_REFINER, Refiner, RefinerOn, SharedRefiner};
use guava::render::{GpuAvatar, HeadlessRenderer, read_texture_bytes};
use guava::tracking::SourceView;
use guava::view::{
    AvatarRef, Content, Display, Frame, Look, PoseRef, RefineWith, ViewRenderer, ViewReport,
};

const BACKGROUND: [f32; 3] = [0.2, 0.45, 0.7];
const TARGET: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// The synthetic photo's avatar (as the viewer's *Reconstruct synthetic photo* makes it), its
/// body posed at rest, and a small camera turned off the photo's.
fn scene(body: &BodyModel) -> (Arc<Avatar>, PosedBody, guava::camera::Camera) {
    let view = SourceView {
        pose: BodyPose::rest(body),
        camera: guava::synthetic::upper_body_camera(body, 0.35),
        crop: None,
    };
    let pixels = guava::synthetic::photo(body, &view.pose, &view.camera, |p| {
        guava::synthetic::banded_texture(p)
    })
    .expect("photo");
    let photo = Photo::Pixels {
        name: "synthetic.png",
        pixels,
        has_alpha: true,
    };
    let outcome = Pipeline::default()
        .reconstruct(
            guava::pipeline::Mode::Default(body),
            photo,
            Tracked::Given(view.clone()),
            &mut |_| true,
        )
        .expect("reconstructs");
    let mut posed = PosedBody::default();
    body.pose(&view.pose, &mut posed).expect("poses");
    let camera = guava::synthetic::upper_body_camera(body, 0.6).scaled(0.25);
    (Arc::new(outcome.avatar), posed, camera)
}

/// Prepares `frame` until `done` (submitting and waiting each time, as frames go by), then
/// presents it into an 8-bit target and reads it back.
fn present(
    gpu: &GpuContext,
    view: &mut ViewRenderer,
    frame: &Frame,
    report: &mut ViewReport,
    done: impl Fn(&ViewReport) -> bool,
) -> image::RgbImage {
    let (device, queue) = (&gpu.device, &gpu.queue);
    for _ in 0..200 {
        queue.submit(view.prepare(device, queue, frame, report));
        guava::render::wait(device);
        if done(report) {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    assert!(done(report), "the view never got there: {report:?}");
    let (w, h) = (frame.camera.width, frame.camera.height);
    let target = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("test target"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: TARGET,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let target = target.create_view(&Default::default());
        let mut pass = encoder
            .begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("test present"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations::default(),
                })],
                ..Default::default()
            })
            .forget_lifetime();
        view.paint(&mut pass, frame);
    }
    queue.submit([encoder.finish()]);
    let rgba = read_texture_bytes(device, queue, &target);
    let rgb = rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    image::RgbImage::from_raw(w, h, rgb).expect("size")
}

/// The largest difference between two 8-bit images, in levels.
fn levels(a: &image::RgbImage, b: &image::RgbImage) -> u8 {
    assert_eq!(a.dimensions(), b.dimensions());
    a.as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| x.abs_diff(*y))
        .max()
        .unwrap_or(0)
}

/// The off-screen path's picture: drawn on black, refined by `refiner` (or not), composited.
fn offscreen(
    renderer: &mut HeadlessRenderer,
    avatar: &Avatar,
    body: &BodyModel,
    posed: &PosedBody,
    camera: &guava::camera::Camera,
    refiner: Option<&mut Refiner>,
) -> image::RgbImage {
    let mut gpu = GpuAvatar::new(
        &renderer.gpu.device,
        renderer.pipelines.clone(),
        avatar,
        &body.triangles,
        body.weld(),
    );
    let black = vec![0.0; avatar.channels];
    renderer
        .draw_avatar(&mut gpu, posed, camera, &black)
        .expect("draws");
    let image = match refiner {
        Some(r) => r.refine_drawn(renderer).expect("refines"),
        None => renderer
            .splatter
            .read_image(&renderer.gpu.device, &renderer.gpu.queue)
            .expect("image"),
    };
    image.over(BACKGROUND)
}

/// Bound: one level of 8 bits. The view and the off-screen path run the same splatting and
/// the same refiner on the same device; the view composites the background in its present
/// pass (the off-screen path on the CPU), so the two differ by float rounding before the
/// quantisation to 8 bits.
#[test]
fn the_view_refines_its_own_frame_as_the_offscreen_path_does() {
    let body = BodyModel::default_body().expect("body");
    let (avatar, posed, camera) = scene(&body);
    let gpu = crate::common::gpu();
    let mut view = ViewRenderer::new(&gpu.device, &gpu.queue, &gpu.adapter.get_info(), TARGET);
    let mut renderer = HeadlessRenderer::with_pipelines(gpu.clone(), view.pipelines());
    let mut background = vec![0.0; avatar.channels];
    background[..3].copy_from_slice(&BACKGROUND);
    let frame = |refine: Option<RefineWith>| Frame {
        content: Content::Avatar {
            avatar: AvatarRef {
                id: 1,
                avatar: avatar.clone(),
                triangles: Arc::new(body.triangles.clone()),
                weld: body.weld().map(|w| Arc::new(w.to_vec())),
                hands: None,
            },
            pose: PoseRef {
                id: 1,
                posed: Arc::new(posed.clone()),
            },
            look: Look {
                background: background.clone(),
                display: Display::default(),
            },
            outside: false,
        },
        camera,
        scale: 1.0,
        preview: false,
        pane: 0,
        refine,
    };
    let mut report = ViewReport::default();

    let raw = present(&gpu, &mut view, &frame(None), &mut report, |r| {
        r.renders > 0
    });
    let expected = offscreen(&mut renderer, &avatar, &body, &posed, &camera, None);
    let raw_levels = levels(&raw, &expected);

    let mut refined = Vec::new();
    for on in [RefinerOn::Cpu, RefinerOn::Gpu] {
        let path = Path::new(DEFAULT_REFINER);
        let loaded = Refiner::load_on(on, &gpu, path).expect("loads");
        let engine = loaded.engine_name().to_string();
        let shared = SharedRefiner::default();
        let with = RefineWith {
            refiner: shared.clone(),
            path: path.to_path_buf(),
            on,
            behind: false,
            wake: None,
        };
        *shared.lock().expect("unlocked") = Some(loaded);
        let before = report.refine.frames;
        let shown = present(&gpu, &mut view, &frame(Some(with)), &mut report, |r| {
            r.refine.frames > before && r.refine.showing
        });
        assert_eq!(report.refine.engine.as_deref(), Some(engine.as_str()));
        let mut guard = shared.lock().expect("unlocked");
        let expected = offscreen(
            &mut renderer,
            &avatar,
            &body,
            &posed,
            &camera,
            guard.as_mut(),
        );
        refined.push((on, levels(&shown, &expected), levels(&shown, &raw)));
    }
    println!(
        "view vs off-screen, in 8-bit levels: raw {raw_levels}; refined {refined:?} \
         (where, vs off-screen, vs the raw frame)"
    );
    assert!(raw_levels <= 1, "raw: {raw_levels}");
    for (on, offscreen, from_raw) in refined {
        assert!(
            offscreen <= 1,
            "{on:?}: {offscreen} levels from the off-screen path"
        );
        assert!(
            from_raw > 8,
            "{on:?}: the refiner changed the picture ({from_raw} levels)"
        );
    }
    // Splatted once (the refiners read that frame), the avatar uploaded once.
    assert_eq!(
        (report.renders, report.avatar_uploads),
        (1, 1),
        "{report:?}"
    );
}
