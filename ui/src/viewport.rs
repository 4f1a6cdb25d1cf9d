//! The central viewport: one egui_wgpu paint callback on egui's own device. Long-lived GPU state
//! (pipelines, the splatter, the present pass) lives once in `callback_resources`; the per-view
//! state (camera, cloud, display settings) rides in the callback value. `prepare` records the
//! splatting pass only when that state changed since the last render; `paint` only composites.

use guava::camera::Camera;
use guava::gaussians::GaussianCloud;
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

pub struct SplatCallback {
    pub scene: SceneRef,
    pub camera: Camera,
    pub background: Vec<f32>,
    pub display: DisplaySettings,
    pub report: Arc<Mutex<ViewportReport>>,
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
}

impl ViewportResources {
    pub fn new(
        device: &wgpu::Device,
        adapter: &wgpu::AdapterInfo,
        target: wgpu::TextureFormat,
    ) -> Self {
        let pipelines = Arc::new(SplatPipelines::new(
            device,
            RasterTuning::for_adapter(adapter),
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
        }
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

impl egui_wgpu::CallbackTrait for SplatCallback {
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
        if let Some(stats) = res.poll_stats(device) {
            if res.splatter.grow_for(device, &stats) {
                res.last = None;
                report.needs_redraw = true;
            }
            report.stats = Some(stats);
        }
        if res.uploaded != Some(self.scene.generation) {
            // Marked uploaded either way: a cloud that does not fit is reported once, not every frame.
            res.uploaded = Some(self.scene.generation);
            res.last = None;
            if let Err(e) = res.splatter.upload(device, queue, &self.scene.cloud) {
                report.error = Some(e.to_string());
            }
        }
        let key = RenderKey {
            generation: self.scene.generation,
            camera: self.camera,
            background: self.background.clone(),
        };
        let mut buffers = Vec::new();
        if res.last.as_ref() != Some(&key) {
            res.splatter
                .prepare(device, queue, &self.camera, &self.background);
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("Viewport::splat"),
            });
            res.splatter.encode(&mut encoder, None);
            if matches!(res.stats_state, StatsReadback::Idle) {
                encoder.copy_buffer_to_buffer(
                    res.splatter.stats_buffer(),
                    0,
                    &res.stats_staging,
                    0,
                    32,
                );
                res.stats_state = StatsReadback::Copied;
            }
            buffers.push(encoder.finish());
            res.present_bind = res
                .present
                .bind(device, &res.present_uniform, &res.splatter);
            res.last = Some(key);
            report.renders += 1;
        } else if matches!(
            res.stats_state,
            StatsReadback::Copied | StatsReadback::Mapping(_)
        ) {
            report.needs_redraw = true;
        }
        let d = &self.display;
        let uniform = res.present.uniform(
            [self.camera.width, self.camera.height],
            d.mode,
            d.rgb_channels,
            d.inv_depth_range,
        );
        queue.write_buffer(&res.present_uniform, 0, bytemuck::bytes_of(&uniform));
        buffers
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
        if let Some(bind) = &res.present_bind {
            res.present.draw(pass, bind);
        }
    }
}
