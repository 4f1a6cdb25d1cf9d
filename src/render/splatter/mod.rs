//! The wgpu splatting pass for one view: owns the cloud's GPU buffers and the view's work and
//! output buffers, and records preprocess → depth sort → tile keys → tile sort → tile ranges →
//! rasterize into an encoder. Buffers are reused across frames and only reallocated when the cloud,
//! the channel count, the resolution or the tile-pair count outgrows them.
//!
//! The output stays on the GPU for the refiner and the present pass: `features()` is an
//! rgba32float texture array holding the channels four to a texel (channel c in layer c / 4, lane
//! c % 4); `aux()` is one rg32float layer of alpha and inverse depth.

mod buffers;

use super::layout::{FrameUniform, GpuGaussian, PROJECTED_SIZE};
use super::pipelines::{FeatureStorage, SplatPipelines, dispatch_1d};
use super::readback::{TextureCopy, read_buffers, read_texture_floats, wait};
use super::timing::StageTimer;
use super::{RenderStats, SplatError, SplatImage};
use crate::camera::Camera;
use crate::gaussians::GaussianCloud;
use crate::gaussians::LowPass;
use buffers::{Bindings, CloudBuffers, ViewBuffers, storage};
use std::sync::Arc;

/// The GPU stages, in order; benchmarks time each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    Preprocess,
    DepthSort,
    TileKeys,
    TileSort,
    TileRanges,
    Rasterize,
}

impl Stage {
    pub const ALL: [Stage; 6] = [
        Stage::Preprocess,
        Stage::DepthSort,
        Stage::TileKeys,
        Stage::TileSort,
        Stage::TileRanges,
        Stage::Rasterize,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Preprocess => "preprocess",
            Stage::DepthSort => "depth sort",
            Stage::TileKeys => "tile keys",
            Stage::TileSort => "tile sort",
            Stage::TileRanges => "tile ranges",
            Stage::Rasterize => "rasterize",
        }
    }
}

/// The frame's counters (RenderStats::from_words), in bytes.
pub const STATS_BYTES: u64 = 9 * 4;
const MIN_GAUSSIANS: u32 = 256;
const MIN_PAIRS: u32 = 1 << 16;

pub struct Splatter {
    pipes: Arc<SplatPipelines>,
    frame: wgpu::Buffer,
    stats: wgpu::Buffer,
    /// [0] pairs needed, [1] pairs kept.
    pair_count: wgpu::Buffer,
    /// [0] number of Gaussians: the depth sort's element count.
    depth_count: wgpu::Buffer,
    cloud: Option<CloudBuffers>,
    view: Option<ViewBuffers>,
    bindings: Option<Bindings>,
    num_gaussians: u32,
    buffers_generation: u64,
    camera: Option<Camera>,
    max_pairs: u32,
    /// How what it holds is low-passed: the uploaded cloud's, or the attached avatar's.
    low_pass: LowPass,
}

/// Floats per Gaussian in the GPU feature buffer: the channels padded to a multiple of four, which
/// the rasterizer reads as vec4s.
pub fn feature_stride(channels: u32) -> u32 {
    channels.div_ceil(4) * 4
}

/// Bytes of one Gaussian's features in the GPU feature buffer.
pub fn feature_bytes(channels: u32, storage: FeatureStorage) -> u64 {
    feature_stride(channels) as u64 * storage.channel_bytes()
}

/// `features` (`channels` a Gaussian) zero-padded to `stride` a Gaussian, each value `to`'s.
fn padded<T: bytemuck::Pod + Default>(
    features: &[f32],
    channels: usize,
    stride: usize,
    to: impl Fn(f32) -> T,
) -> Vec<T> {
    let mut out = vec![T::default(); features.len() / channels * stride];
    for (o, f) in out
        .chunks_exact_mut(stride)
        .zip(features.chunks_exact(channels))
    {
        for (t, v) in o.iter_mut().zip(f) {
            *t = to(*v);
        }
    }
    out
}

/// The largest cloud with `channels` channels stored as `storage` whose buffers the device can
/// bind.
pub fn max_gaussians(limits: &wgpu::Limits, channels: u32, storage: FeatureStorage) -> u64 {
    let max_binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let per_gaussian = feature_bytes(channels, storage).max(size_of::<GpuGaussian>() as u64);
    (max_binding / per_gaussian).min(u32::MAX as u64)
}

/// The first `channels` channels of texels of `lanes` channels each, layer-major as a texture
/// array reads back ([L, H, W, lanes]; channel c in layer c / lanes, lane c % lanes), as planes
/// ([C, H, W]).
fn planes(texels: &[f32], lanes: usize, channels: usize) -> Vec<f32> {
    let layers = channels.div_ceil(lanes);
    let pixels = texels.len() / (layers * lanes).max(1);
    (0..channels)
        .flat_map(|c| {
            let layer = &texels[c / lanes * pixels * lanes..][..pixels * lanes];
            layer.iter().skip(c % lanes).step_by(lanes).copied()
        })
        .collect()
}

/// The splat output on its way to the CPU: copied by a command encoder, mapped once that is
/// submitted ([`ImageCopy::map`]), read after the device is polled past it.
pub struct ImageCopy {
    features: TextureCopy,
    aux: TextureCopy,
    size: [u32; 2],
    channels: usize,
}

impl ImageCopy {
    pub fn map(&self) {
        self.features.map();
        self.aux.map();
    }

    /// The image (call after the mapping completed).
    pub fn image(&self) -> SplatImage {
        let features: Vec<f32> = bytemuck::pod_collect_to_vec(&self.features.bytes());
        let aux: Vec<f32> = bytemuck::pod_collect_to_vec(&self.aux.bytes());
        let mut alpha = planes(&aux, 2, 2);
        let inv_depth = alpha.split_off(aux.len() / 2);
        SplatImage {
            width: self.size[0],
            height: self.size[1],
            channels: self.channels,
            features: planes(&features, 4, self.channels),
            alpha,
            inv_depth,
        }
    }
}

/// A view of every layer as a 2D array, also for single-layer textures (whose default view is 2D).
pub fn array_view(texture: &wgpu::Texture) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}

impl Splatter {
    pub fn new(device: &wgpu::Device, pipes: Arc<SplatPipelines>) -> Self {
        let limits = device.limits();
        let max_bytes = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        Self {
            frame: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Splat::frame"),
                size: size_of::<FrameUniform>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            stats: storage(device, "Splat::stats", STATS_BYTES),
            pair_count: storage(device, "Splat::pair_count", 8),
            depth_count: storage(device, "Splat::depth_count", 4),
            pipes,
            cloud: None,
            view: None,
            bindings: None,
            num_gaussians: 0,
            buffers_generation: 0,
            camera: None,
            max_pairs: (max_bytes / 4).min(u32::MAX as u64) as u32,
            low_pass: LowPass::default(),
        }
    }

    pub fn num_gaussians(&self) -> u32 {
        self.num_gaussians
    }

    pub fn channels(&self) -> Option<u32> {
        self.cloud.as_ref().map(|c| c.channels)
    }

    /// Uploads a cloud; reallocates (with headroom) only if it outgrows the buffers or changes
    /// channel count. Fails, keeping the previous cloud, if the adapter cannot bind buffers this big.
    pub fn upload(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        cloud: &GaussianCloud,
    ) -> Result<(), SplatError> {
        self.reserve(device, queue, cloud.len(), cloud.channels as u32)?;
        let Some(buffers) = &self.cloud else {
            return Ok(());
        };
        let gpu: Vec<GpuGaussian> = (0..cloud.len())
            .map(|i| GpuGaussian {
                pos: cloud.positions[i],
                opacity: cloud.opacities[i],
                rot: cloud.rotations[i],
                scale: cloud.scales[i],
                _pad: 0.0,
            })
            .collect();
        queue.write_buffer(&buffers.gaussians, 0, bytemuck::cast_slice(&gpu));
        self.write_features(queue, &cloud.features);
        self.low_pass = cloud.low_pass;
        Ok(())
    }

    /// How the Gaussians written by something else (the rig pass) are low-passed.
    pub fn set_low_pass(&mut self, low_pass: LowPass) {
        self.low_pass = low_pass;
    }

    /// Makes room for `count` Gaussians of `channels` channels, whose attributes something else
    /// writes ([`Self::gaussian_buffer`]: the rig pass, or [`Self::upload`]) and whose features
    /// go in by [`Self::write_features`]. Reallocates (with headroom) only when they outgrow the
    /// buffers or the channel count changes; then [`Self::buffers_generation`] changes and their
    /// contents are lost. Fails, keeping what was there, if the adapter cannot bind buffers this
    /// big.
    pub fn reserve(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        count: usize,
        channels: u32,
    ) -> Result<(), SplatError> {
        let max_count = max_gaussians(&device.limits(), channels, self.pipes.storage);
        if count as u64 > max_count {
            return Err(SplatError::TooManyGaussians {
                count: count as u64,
                channels,
                max: max_count,
            });
        }
        let n = count as u32;
        let fits = self
            .cloud
            .as_ref()
            .is_some_and(|c| c.capacity >= n && c.channels == channels);
        if !fits {
            let capacity = (n as u64 + n as u64 / 4)
                .clamp(MIN_GAUSSIANS as u64, max_count.max(MIN_GAUSSIANS as u64))
                as u32;
            self.cloud = Some(Self::alloc_cloud(
                device,
                capacity,
                channels,
                self.pipes.storage,
            ));
            self.bindings = None;
            self.buffers_generation += 1;
        }
        queue.write_buffer(&self.depth_count, 0, bytemuck::bytes_of(&n));
        self.num_gaussians = n;
        Ok(())
    }

    /// Writes the features of the reserved Gaussians (`channels` per Gaussian, Gaussian-major),
    /// padded to the stride the rasterizer reads.
    pub fn write_features(&self, queue: &wgpu::Queue, features: &[f32]) {
        let Some(buffers) = &self.cloud else { return };
        let c = buffers.channels as usize;
        let stride = feature_stride(buffers.channels) as usize;
        let write = |bytes: &[u8]| queue.write_buffer(&buffers.features, 0, bytes);
        match self.pipes.storage {
            FeatureStorage::F32 if c == stride => write(bytemuck::cast_slice(features)),
            FeatureStorage::F32 => write(bytemuck::cast_slice(&padded(features, c, stride, |v| v))),
            // Round to nearest; beyond f16's range becomes ±Inf (culled as non-finite).
            FeatureStorage::F16 => write(bytemuck::cast_slice(&padded(features, c, stride, |v| {
                half::f16::from_f32(v).to_bits()
            }))),
        }
    }

    /// The attributes the preprocess reads (one [`GpuGaussian`] each), for passes that write them.
    pub fn gaussian_buffer(&self) -> Option<&wgpu::Buffer> {
        self.cloud.as_ref().map(|c| &c.gaussians)
    }

    /// Changes whenever the Gaussian buffers are reallocated (and their contents lost).
    pub fn buffers_generation(&self) -> u64 {
        self.buffers_generation
    }

    /// The attributes of every Gaussian as the preprocess will read them (waits for the GPU; for
    /// tests).
    pub fn read_gaussians(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Vec<GpuGaussian> {
        let Some(c) = &self.cloud else {
            return Vec::new();
        };
        let size = self.num_gaussians as u64 * size_of::<GpuGaussian>() as u64;
        if size == 0 {
            return Vec::new();
        }
        let bytes = read_buffers(device, queue, &[(&c.gaussians, size)]);
        bytemuck::cast_slice(&bytes[0]).to_vec()
    }

    /// Sets the camera and background for the next [`Self::encode`]; sizes the view's buffers.
    /// Call after [`Self::upload`]. `background` has one value per channel.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        camera: &Camera,
        background: &[f32],
    ) {
        let Some(cloud) = &self.cloud else {
            panic!("Splatter::prepare before any upload");
        };
        assert_eq!(
            background.len() as u32,
            cloud.channels,
            "one background value per channel"
        );
        assert!(
            camera.width > 0 && camera.height > 0,
            "camera image must be at least 1×1"
        );
        let max_side = device.limits().max_texture_dimension_2d;
        assert!(
            camera.width <= max_side && camera.height <= max_side,
            "image {}×{} exceeds the adapter's {max_side}² texture limit",
            camera.width,
            camera.height
        );
        let channels = cloud.channels;
        let pair_capacity = self.view.as_ref().map_or(0, |v| v.pair_capacity);
        let wanted_pairs = pair_capacity
            .max(self.num_gaussians.saturating_mul(4))
            .max(MIN_PAIRS)
            .min(self.max_pairs);
        let fits = self.view.as_ref().is_some_and(|v| {
            v.width == camera.width
                && v.height == camera.height
                && v.channels == channels
                && v.pair_capacity >= wanted_pairs
        });
        if !fits {
            self.view = Some(Self::alloc_view(device, camera, channels, wanted_pairs));
            self.bindings = None;
        }
        if self.bindings.is_none() {
            self.bindings = Some(self.bind(device, camera));
        }
        let (tiles_x, tiles_y) = crate::render::tile_grid(camera);
        let (Some(view), Some(bindings)) = (&self.view, &self.bindings) else {
            return;
        };
        bindings.pair_scan.set_count(queue, self.num_gaussians);
        let frame = FrameUniform {
            view_from_world: camera.view_from_world.to_cols_array_2d(),
            focal: [camera.fx, camera.fy],
            principal: [camera.cx - 0.5, camera.cy - 0.5],
            ewa_lim: camera.ewa_limits(),
            size: [camera.width, camera.height],
            tiles: [tiles_x, tiles_y],
            near: camera.near,
            num_gaussians: self.num_gaussians,
            pair_capacity: view.pair_capacity,
            channels,
            low_pass: match self.low_pass {
                LowPass::Dilated => 0,
                LowPass::Compensated => 1,
            },
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        };
        queue.write_buffer(&self.frame, 0, bytemuck::bytes_of(&frame));
        // Four to a word like the features, zero past the channels.
        let mut padded = background.to_vec();
        padded.resize(feature_stride(channels) as usize, 0.0);
        queue.write_buffer(&view.background, 0, bytemuck::cast_slice(&padded));
        self.camera = Some(*camera);
    }

    /// Records the whole pass. [`Self::prepare`] must have been called for this frame.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder, timer: Option<&StageTimer>) {
        for stage in Stage::ALL {
            self.encode_stage(encoder, stage, timer);
        }
    }

    /// Records one stage (benchmarks submit stages one by one when timestamps are unavailable).
    pub fn encode_stage(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        stage: Stage,
        timer: Option<&StageTimer>,
    ) {
        let (Some(b), Some(v), Some(camera)) = (&self.bindings, &self.view, &self.camera) else {
            log::warn!("splatting pass encoded before prepare; skipped");
            return;
        };
        let pipes = &*self.pipes;
        let gaussian_groups = self.num_gaussians.div_ceil(256);
        match stage {
            Stage::Preprocess => {
                encoder.clear_buffer(&self.stats, 0, None);
                encoder.clear_buffer(&v.ranges, 0, None);
            }
            Stage::TileKeys => encoder.clear_buffer(&self.pair_count, 0, None),
            _ => {}
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(stage.name()),
            timestamp_writes: timer.map(|t| t.writes(stage)),
        });
        match stage {
            Stage::Preprocess => {
                pass.set_pipeline(&pipes.preprocess);
                pass.set_bind_group(0, &b.preprocess, &[]);
                dispatch_1d(&mut pass, gaussian_groups);
            }
            Stage::DepthSort => b.depth_sort.encode(pipes, &mut pass),
            Stage::TileKeys => {
                pass.set_bind_group(0, &b.keys, &[]);
                pass.set_pipeline(&pipes.gather_counts);
                dispatch_1d(&mut pass, gaussian_groups);
                b.pair_scan.encode(pipes, &mut pass);
                pass.set_bind_group(0, &b.keys, &[]);
                pass.set_pipeline(&pipes.clamp_pairs);
                pass.dispatch_workgroups(1, 1, 1);
                pass.set_pipeline(&pipes.emit_keys);
                dispatch_1d(&mut pass, gaussian_groups);
            }
            Stage::TileSort => b.tile_sort.encode(pipes, &mut pass),
            Stage::TileRanges => {
                pass.set_pipeline(&pipes.tile_ranges);
                pass.set_bind_group(0, &b.ranges, &[]);
                dispatch_1d(&mut pass, v.pair_capacity.div_ceil(256));
            }
            Stage::Rasterize => {
                let (tx, ty) = crate::render::tile_grid(camera);
                pass.set_pipeline(&b.rasterize_pipeline);
                pass.set_bind_group(0, &b.rasterize, &[]);
                pass.dispatch_workgroups(tx, ty, 1);
            }
        }
    }

    /// If the last frame needed more tile pairs than fit, grows the pair buffers (once, with
    /// headroom) and returns true: the caller should render again. False when it fits, or when
    /// the device's buffer limit is reached (pairs past it stay dropped and `stats` says so).
    pub fn grow_for(&mut self, device: &wgpu::Device, stats: &RenderStats) -> bool {
        let Some(view) = &self.view else { return false };
        if stats.tile_pairs_needed <= view.pair_capacity as u64
            || view.pair_capacity >= self.max_pairs
        {
            return false;
        }
        let wanted = (stats.tile_pairs_needed + stats.tile_pairs_needed / 4)
            .min(self.max_pairs as u64) as u32;
        let Some(camera) = self.camera else {
            return false;
        };
        self.view = Some(Self::alloc_view(device, &camera, view.channels, wanted));
        self.bindings = Some(self.bind(device, &camera));
        true
    }

    /// The C channels four to a texel (rgba32float, ⌈C/4⌉ layers; channel c in layer c / 4, lane
    /// c % 4), on the GPU.
    pub fn features(&self) -> Option<&wgpu::Texture> {
        self.view.as_ref().map(|v| &v.out_features)
    }

    /// Alpha and inverse depth (rg32float, one layer), on the GPU.
    pub fn aux(&self) -> Option<&wgpu::Texture> {
        self.view.as_ref().map(|v| &v.out_aux)
    }

    pub fn stats_buffer(&self) -> &wgpu::Buffer {
        &self.stats
    }

    pub fn read_stats(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> RenderStats {
        let bytes = read_buffers(device, queue, &[(&self.stats, STATS_BYTES)]);
        RenderStats::from_words(self.num_gaussians, bytemuck::cast_slice(&bytes[0]))
    }

    /// Copies the output to the CPU (waits for the GPU).
    pub fn read_image(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Option<SplatImage> {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("Splatter::read_image"),
        });
        let copy = self.copy_image(device, &mut encoder)?;
        queue.submit([encoder.finish()]);
        copy.map();
        wait(device);
        Some(copy.image())
    }

    /// Records a copy of the output to staging, to be read once submitted ([`ImageCopy`]).
    pub fn copy_image(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Option<ImageCopy> {
        let v = self.view.as_ref()?;
        Some(ImageCopy {
            features: TextureCopy::encode(device, encoder, &v.out_features),
            aux: TextureCopy::encode(device, encoder, &v.out_aux),
            size: [v.width, v.height],
            channels: v.channels as usize,
        })
    }

    /// Copies alpha and inverse depth to the CPU, each [H, W] (waits for the GPU).
    pub fn read_aux(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Option<[Vec<f32>; 2]> {
        let aux = read_texture_floats(device, queue, &self.view.as_ref()?.out_aux);
        let mut planes = planes(&aux, 2, 2);
        let inv_depth = planes.split_off(aux.len() / 2);
        Some([planes, inv_depth])
    }

    /// GPU memory held: (bytes per Gaussian of capacity, bytes per tile pair of capacity, the rest).
    pub fn memory(&self) -> MemoryUse {
        let per_gaussian = |c: &CloudBuffers| {
            size_of::<GpuGaussian>() as u64
                + feature_bytes(c.channels, self.pipes.storage)
                + PROJECTED_SIZE
                + 6 * 4
        };
        MemoryUse {
            gaussian_capacity: self.cloud.as_ref().map_or(0, |c| c.capacity as u64),
            bytes_per_gaussian: self.cloud.as_ref().map_or(0, per_gaussian),
            pair_capacity: self.view.as_ref().map_or(0, |v| v.pair_capacity as u64),
            bytes_per_pair: 16,
            image_bytes: self.view.as_ref().map_or(0, |v| {
                v.width as u64 * v.height as u64 * (feature_stride(v.channels) as u64 + 2) * 4
            }),
        }
    }
}

#[derive(Clone, Copy, Debug, Default)]
pub struct MemoryUse {
    pub gaussian_capacity: u64,
    pub bytes_per_gaussian: u64,
    pub pair_capacity: u64,
    pub bytes_per_pair: u64,
    pub image_bytes: u64,
}

impl MemoryUse {
    pub fn total(&self) -> u64 {
        self.gaussian_capacity * self.bytes_per_gaussian
            + self.pair_capacity * self.bytes_per_pair
            + self.image_bytes
    }
}
