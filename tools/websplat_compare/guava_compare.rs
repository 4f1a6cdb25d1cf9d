//! Times web-splat's library (KeKsBoTer/web-splat) on a PLY with the scene `guava bench splat`
//! uses: 512², camera at (0, 0, −3) looking along +z, 50° field of view, black background.
//! `tools/compare_websplat.sh` copies this file into a web-splat checkout as a binary and runs it
//! beside our bench; it is not part of our workspace.
//!
//! Usage: guava_compare PLY [FRAMES=9] [SAVE.png]
//! Each frame is prepare (web-splat's GPU sort) + render + submit + wait, after two warm-ups;
//! prints the median. `walltime` is 100 s: web-splat grows the cloud in over its first seconds,
//! and at 1 s it draws only the Gaussians near the centre.
use cgmath::{Deg, Point3, Quaternion, Vector2};
use std::fs::File;
use std::time::{Duration, Instant};
use web_splats::{
    io::GenericGaussianPointCloud, GaussianRenderer, PerspectiveCamera, PerspectiveProjection,
    PointCloud, SplattingArgs, WGPUContext,
};

const SIDE: u32 = 512;
const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

#[pollster::main]
async fn main() {
    let args: Vec<String> = std::env::args().collect();
    let ply = args
        .get(1)
        .expect("usage: guava_compare PLY [FRAMES] [SAVE.png]");
    let frames: usize = args
        .get(2)
        .map_or(9, |s| s.parse().expect("FRAMES: a count"));
    let save = args.get(3);

    let ctx = WGPUContext::new_instance().await;
    let info = ctx.adapter.get_info();
    println!(
        "adapter: {} · {:?} · {:?}",
        info.name, info.backend, info.device_type
    );
    let (device, queue) = (&ctx.device, &ctx.queue);
    let file = File::open(ply).unwrap_or_else(|e| panic!("{ply}: {e}"));
    let cloud = GenericGaussianPointCloud::load(file).unwrap_or_else(|e| panic!("{ply}: {e}"));
    let cloud = PointCloud::new(device, cloud).expect("upload the cloud");
    let mut renderer =
        GaussianRenderer::new(device, queue, FORMAT, cloud.sh_deg(), cloud.compressed()).await;

    let extent = wgpu::Extent3d {
        width: SIDE,
        height: SIDE,
        depth_or_array_layers: 1,
    };
    let target = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("guava_compare target"),
        size: extent,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: FORMAT,
        usage: wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    let view = target.create_view(&Default::default());
    let viewport = Vector2::new(SIDE, SIDE);
    let camera = PerspectiveCamera::new(
        Point3::new(0.0, 0.0, -3.0),
        Quaternion::new(1.0, 0.0, 0.0, 0.0),
        PerspectiveProjection::new(viewport, Vector2::new(Deg(50.0), Deg(50.0)), 0.01, 100.0),
    );

    let mut times = Vec::with_capacity(frames);
    for i in 0..frames + 2 {
        let start = Instant::now();
        let mut encoder = device.create_command_encoder(&Default::default());
        let args = SplattingArgs {
            camera,
            viewport,
            gaussian_scaling: 1.0,
            max_sh_deg: cloud.sh_deg(),
            mip_splatting: None,
            kernel_size: None,
            clipping_box: None,
            walltime: Duration::from_secs(100),
            scene_center: None,
            scene_extend: None,
            background_color: wgpu::Color::BLACK,
        };
        renderer.prepare(&mut encoder, device, queue, &cloud, args, &mut None);
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: None,
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
            });
            renderer.render(&mut pass, &cloud);
        }
        queue.submit(Some(encoder.finish()));
        device
            .poll(wgpu::PollType::Wait)
            .expect("wait for the frame");
        if i >= 2 {
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    if let Some(path) = save {
        save_png(device, queue, &target, extent, path);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "web-splat median {:.1} ms over {frames} frames",
        times[times.len() / 2]
    );
}

/// Reads the target back so a person can check web-splat drew the whole cloud.
fn save_png(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    target: &wgpu::Texture,
    extent: wgpu::Extent3d,
    path: &str,
) {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: u64::from(SIDE * SIDE * 4),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        target.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(SIDE * 4),
                rows_per_image: Some(SIDE),
            },
        },
        extent,
    );
    queue.submit(Some(encoder.finish()));
    buffer.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    device
        .poll(wgpu::PollType::Wait)
        .expect("wait for the readback");
    let pixels = buffer.slice(..).get_mapped_range().to_vec();
    image::RgbaImage::from_raw(SIDE, SIDE, pixels)
        .expect("a whole image")
        .save(path)
        .unwrap_or_else(|e| panic!("{path}: {e}"));
}
