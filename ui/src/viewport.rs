//! The central viewport: one egui_wgpu paint callback on egui's own device. Long-lived GPU state
//! (pipelines, the splatter, the present pass, the mesh pass) lives once in `callback_resources`;
//! the per-view state (what to show, camera, display settings) rides in the callback value.
//! `prepare` records a pass only when that state changed since the last render; `paint` only
//! composites.

use glam::Vec3;
use guava::camera::Camera;
use guava::gaussians::GaussianCloud;
use guava::render::mesh::{MeshPass, MeshStyle};
use guava::render::present::{PresentMode, PresentPass};
use guava::render::{RasterTuning, RenderStats, SplatPipelines, Splatter};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// What the viewport tells the app, for the HUD.
#[derive(Clone, Debug, Default)]
pub struct ViewportReport {
    pub stats: Option<RenderStats>,
    /// Frames the splatting pass actually ran (it is skipped when nothing changed).
    pub renders: u64,
    /// Set when the pass must run again (tile-pair buffers grew): the app requests a repaint.
    pub needs_redraw: bool,
    /// A scene the GPU could not take (too large for the adapter); the app shows it once.
    pub error: Option<String>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct DisplaySettings {
    pub mode: PresentMode,
    pub rgb_channels: [u32; 3],
    pub inv_depth_range: [f32; 2],
}

impl Default for DisplaySettings {
    fn default() -> Self {
        Self {
            mode: PresentMode::Rgb,
            rgb_channels: [0, 1, 2],
            inv_depth_range: [0.0, 1.0],
        }
    }
}

/// A cloud with a generation number, so the viewport uploads each cloud once.
#[derive(Clone)]
pub struct SceneRef {
    pub generation: u64,
    pub cloud: Arc<GaussianCloud>,
}

/// A posed body for the mesh view. `topology` changes with the body model, `pose` with every
/// re-pose, so the viewport uploads each only once.
#[derive(Clone)]
pub struct BodyFrame {
    pub topology: u64,
    pub pose: u64,
    pub triangles: Arc<Vec<[u32; 3]>>,
    pub positions: Arc<Vec<Vec3>>,
    pub normals: Arc<Vec<Vec3>>,
    pub style: MeshStyle,
}

/// What the viewport shows this frame.
#[derive(Clone)]
pub enum Content {
    Splats {
        scene: SceneRef,
        background: Vec<f32>,
        display: DisplaySettings,
    },
    Body(BodyFrame),
}

pub struct ViewportCallback {
    pub content: Content,
    pub camera: Camera,
    pub report: Arc<Mutex<ViewportReport>>,
}

#[derive(PartialEq)]
struct MeshKey {
    pose: u64,
    camera: Camera,
    style: MeshStyle,
}

#[derive(PartialEq)]
struct RenderKey {
    generation: u64,
    camera: Camera,
    background: Vec<f32>,
}

enum StatsReadback {
    Idle,
    Copied,
    Mapping(Arc<AtomicBool>),
}

pub struct ViewportResources {
    splatter: Splatter,
    present: PresentPass,
    present_uniform: wgpu::Buffer,
    present_bind: Option<wgpu::BindGroup>,
    uploaded: Option<u64>,
    last: Option<RenderKey>,
    stats_staging: wgpu::Buffer,
    stats_state: StatsReadback,
    mesh: MeshPass,
    mesh_topology: Option<u64>,
    mesh_uploaded: Option<u64>,
    mesh_last: Option<MeshKey>,
}

impl ViewportResources {
    pub fn new(
        device: &wgpu::Device,
        adapter: &wgpu::AdapterInfo,
        target: wgpu::TextureFormat,
    ) -> Self {
        let pipelines = Arc::new(SplatPipelines::new(
            device,
            RasterTuning::for_device(adapter, device.features()),
        ));
        Self {
            splatter: Splatter::new(device, pipelines),
            present: PresentPass::new(device, target),
            present_uniform: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Viewport::present_uniform"),
                size: size_of::<guava::render::present::PresentUniform>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            present_bind: None,
            uploaded: None,
            last: None,
            stats_staging: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Viewport::stats_staging"),
                size: 32,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
            stats_state: StatsReadback::Idle,
            mesh: MeshPass::new(device, Some(target)),
            mesh_topology: None,
            mesh_uploaded: None,
            mesh_last: None,
        }
    }

    /// Re-draws the mesh view when the pose, camera or style changed.
    fn prepare_body(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        body: &BodyFrame,
        camera: &Camera,
        report: &mut ViewportReport,
    ) -> Option<wgpu::CommandBuffer> {
        if self.mesh_topology != Some(body.topology) {
            self.mesh
                .set_topology(device, body.positions.len(), &body.triangles);
            self.mesh_topology = Some(body.topology);
            // A new body: its first pose generation may equal the old body's last one.
            self.mesh_uploaded = None;
            self.mesh_last = None;
        }
        if self.mesh_uploaded != Some(body.pose) {
            self.mesh
                .set_vertices(queue, &body.positions, &body.normals);
            self.mesh_uploaded = Some(body.pose);
        }
        let key = MeshKey {
            pose: body.pose,
            camera: *camera,
            style: body.style,
        };
        if self.mesh_last.as_ref() == Some(&key) {
            return None;
        }
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("Viewport::mesh"),
        });
        self.mesh
            .encode(device, queue, &mut encoder, camera, &body.style);
        self.mesh_last = Some(key);
        report.renders += 1;
        Some(encoder.finish())
    }

    /// Advances the non-blocking stats readback; returns stats when a copy has landed.
    fn poll_stats(&mut self, device: &wgpu::Device) -> Option<RenderStats> {
        match &self.stats_state {
            StatsReadback::Idle => None,
            StatsReadback::Copied => {
                // The copy was submitted last frame: now the buffer may be mapped.
                let done = Arc::new(AtomicBool::new(false));
                let flag = done.clone();
                self.stats_staging
                    .slice(..)
                    .map_async(wgpu::MapMode::Read, move |r| {
                        flag.store(r.is_ok(), Ordering::Release)
                    });
                self.stats_state = StatsReadback::Mapping(done);
                None
            }
            StatsReadback::Mapping(done) => {
                let _ = device.poll(wgpu::PollType::Poll);
                if !done.load(Ordering::Acquire) {
                    return None;
                }
                let words: Vec<u32> = self
                    .stats_staging
                    .slice(..)
                    .get_mapped_range()
                    .map(|v| bytemuck::cast_slice(&v).to_vec())
                    .unwrap_or_default();
                self.stats_staging.unmap();
                self.stats_state = StatsReadback::Idle;
                (words.len() == 8)
                    .then(|| RenderStats::from_words(self.splatter.num_gaussians(), &words))
            }
        }
    }
}

impl ViewportResources {
    /// Re-splats when the cloud, camera or background changed; updates the present uniform.
    #[allow(clippy::too_many_arguments)]
    fn prepare_splats(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &SceneRef,
        background: &[f32],
        display: &DisplaySettings,
        camera: &Camera,
        report: &mut ViewportReport,
    ) -> Option<wgpu::CommandBuffer> {
        if let Some(stats) = self.poll_stats(device) {
            if self.splatter.grow_for(device, &stats) {
                self.last = None;
                report.needs_redraw = true;
            }
            report.stats = Some(stats);
        }
        if self.uploaded != Some(scene.generation) {
            // Marked uploaded either way: a cloud that does not fit is reported once, not every frame.
            self.uploaded = Some(scene.generation);
            self.last = None;
            if let Err(e) = self.splatter.upload(device, queue, &scene.cloud) {
                report.error = Some(e.to_string());
            }
        }
        let key = RenderKey {
            generation: scene.generation,
            camera: *camera,
            background: background.to_vec(),
        };
        let mut buffer = None;
        if self.last.as_ref() != Some(&key) {
            self.splatter.prepare(device, queue, camera, background);
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("Viewport::splat"),
            });
            self.splatter.encode(&mut encoder, None);
            if matches!(self.stats_state, StatsReadback::Idle) {
                encoder.copy_buffer_to_buffer(
                    self.splatter.stats_buffer(),
                    0,
                    &self.stats_staging,
                    0,
                    32,
                );
                self.stats_state = StatsReadback::Copied;
            }
            buffer = Some(encoder.finish());
            self.present_bind = self
                .present
                .bind(device, &self.present_uniform, &self.splatter);
            self.last = Some(key);
            report.renders += 1;
        } else if matches!(
            self.stats_state,
            StatsReadback::Copied | StatsReadback::Mapping(_)
        ) {
            report.needs_redraw = true;
        }
        let uniform = self.present.uniform(
            [camera.width, camera.height],
            display.mode,
            display.rgb_channels,
            display.inv_depth_range,
        );
        queue.write_buffer(&self.present_uniform, 0, bytemuck::bytes_of(&uniform));
        buffer
    }
}

impl egui_wgpu::CallbackTrait for ViewportCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &egui_wgpu::ScreenDescriptor,
        _egui_encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(res) = resources.get_mut::<ViewportResources>() else {
            log::error!("viewport resources missing; nothing drawn");
            return Vec::new();
        };
        let mut report = self.report.lock().unwrap_or_else(|e| e.into_inner());
        let buffer = match &self.content {
            Content::Splats {
                scene,
                background,
                display,
            } => res.prepare_splats(
                device,
                queue,
                scene,
                background,
                display,
                &self.camera,
                &mut report,
            ),
            Content::Body(body) => res.prepare_body(device, queue, body, &self.camera, &mut report),
        };
        buffer.into_iter().collect()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        let Some(res) = resources.get::<ViewportResources>() else {
            return;
        };
        match &self.content {
            Content::Splats { .. } => {
                if let Some(bind) = &res.present_bind {
                    res.present.draw(pass, bind);
                }
            }
            Content::Body(_) => res.mesh.draw_blit(pass),
        }
    }
}
