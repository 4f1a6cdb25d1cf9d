//! Gaussian splatting: the wgpu pass ([`splatter`]), the f64 CPU reference it is tested against
//! ([`reference`](mod@reference)), and the present pass that shows the output in a window ([`present`]).

mod layout;
pub mod mesh;
pub(crate) mod pipelines;
pub mod present;
pub(crate) mod readback;
pub mod reference;
mod rig;
mod scan;
pub mod sequence;
pub(crate) mod shader;
mod sort;
pub mod splatter;
mod timing;

pub use layout::GpuGaussian;
pub use pipelines::{FeatureStorage, RasterTuning, SplatPipelines};
pub use readback::{read_texture_bytes, wait};
pub use rig::GpuAvatar;
pub use splatter::{Splatter, Stage};
pub use timing::StageTimer;

use crate::camera::Camera;
use crate::gaussians::GaussianCloud;
use crate::gpu::GpuContext;
use std::sync::Arc;

#[derive(Debug, thiserror::Error)]
pub enum SplatError {
    #[error(
        "{count} Gaussians with {channels} channels do not fit this adapter's largest storage buffer \
         (at most {max} Gaussians at this channel count)"
    )]
    TooManyGaussians { count: u64, channels: u32, max: u64 },
    #[error("a {width}×{height} image: this adapter draws 1 to {max} pixels a side")]
    ImageSize { width: u32, height: u32, max: u32 },
}

/// An avatar that could not be drawn: too big for the adapter, or posed on another body.
#[derive(Debug, thiserror::Error)]
pub enum AvatarRenderError {
    #[error(transparent)]
    Splat(#[from] SplatError),
    #[error(transparent)]
    Body(#[from] crate::avatar::BodyMismatch),
}

/// Tile side in pixels (`config.h`: BLOCK_X = BLOCK_Y = 16).
pub const TILE_SIZE: u32 = 16;

/// The tile grid covering `camera`'s image: columns, rows.
pub fn tile_grid(camera: &Camera) -> (u32, u32) {
    (
        camera.width.div_ceil(TILE_SIZE),
        camera.height.div_ceil(TILE_SIZE),
    )
}

/// A rendered C-channel image on the CPU: channel-major planes like the reference's [C, H, W].
#[derive(Clone, Debug, PartialEq)]
pub struct SplatImage {
    pub width: u32,
    pub height: u32,
    pub channels: usize,
    pub features: Vec<f32>,
    /// Accumulated alpha, 1 − T.
    pub alpha: Vec<f32>,
    /// Σ αᵢTᵢ/zᵢ, the reference's `invdepth` output.
    pub inv_depth: Vec<f32>,
}

impl SplatImage {
    pub fn new(width: u32, height: u32, channels: usize) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            channels,
            features: vec![0.0; n * channels],
            alpha: vec![0.0; n],
            inv_depth: vec![0.0; n],
        }
    }

    pub fn plane(&self, channel: usize) -> &[f32] {
        let n = self.width as usize * self.height as usize;
        &self.features[channel * n..(channel + 1) * n]
    }

    /// RGB rendered on black (premultiplied) composited over `background`, as 8-bit RGB.
    pub fn over(&self, background: [f32; 3]) -> image::RgbImage {
        let (r, g, b) = (self.plane(0), self.plane(1), self.plane(2));
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        image::RgbImage::from_fn(self.width, self.height, |x, y| {
            let i = (y * self.width + x) as usize;
            let t = 1.0 - self.alpha[i];
            image::Rgb([
                q(r[i] + background[0] * t),
                q(g[i] + background[1] * t),
                q(b[i] + background[2] * t),
            ])
        })
    }

    /// Channels 0..3 (or the one channel, as grey) as 8-bit RGB, clamped to [0, 1].
    pub fn to_rgb8(&self) -> image::RgbImage {
        let pick = |c: usize| self.plane(c.min(self.channels - 1));
        let (r, g, b) = (pick(0), pick(1), pick(2));
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        image::RgbImage::from_fn(self.width, self.height, |x, y| {
            let i = (y * self.width + x) as usize;
            image::Rgb([q(r[i]), q(g[i]), q(b[i])])
        })
    }
}

/// What a frame drew and what it left out. The culled counts partition `input − visible`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RenderStats {
    pub input: u64,
    /// NaN or Inf in any attribute: dropped, never drawn.
    pub nonfinite: u64,
    /// Centre at or in front of the near plane (z ≤ 0.2).
    pub near: u64,
    /// Opacity below 1/255: can never pass the alpha test.
    pub transparent: u64,
    /// Singular or non-finite projected covariance.
    pub degenerate: u64,
    /// 3σ footprint entirely off screen.
    pub outside: u64,
    pub visible: u64,
    /// (tile, Gaussian) pairs drawn.
    pub tile_pairs: u64,
    /// Pairs the frame needed; more than `tile_pairs` only if the buffers could not grow.
    pub tile_pairs_needed: u64,
    /// Tiles the rasterizer stopped short of the end of their list, at the loop budget of CPU
    /// adapters (llvmpipe leaves every loop of a shader invocation past 65535 iterations,
    /// shaders/rasterize.wgsl): their pixels lack the hindmost Gaussians. Zero on GPUs.
    pub tiles_cut_short: u64,
}

impl RenderStats {
    pub(crate) fn count_culled(&mut self, why: reference::Culled) {
        use reference::Culled::*;
        match why {
            NonFinite => self.nonfinite += 1,
            Near => self.near += 1,
            Transparent => self.transparent += 1,
            Degenerate => self.degenerate += 1,
            Outside => self.outside += 1,
        }
    }

    /// From the GPU stats buffer (order fixed in shaders/common.wgsl).
    pub fn from_words(input: u32, w: &[u32]) -> Self {
        Self {
            input: input as u64,
            nonfinite: w[0] as u64,
            near: w[1] as u64,
            transparent: w[2] as u64,
            degenerate: w[3] as u64,
            outside: w[4] as u64,
            visible: w[5] as u64,
            tile_pairs_needed: w[6] as u64,
            tile_pairs: w[7] as u64,
            tiles_cut_short: w[8] as u64,
        }
    }

    pub fn culled(&self) -> u64 {
        self.nonfinite + self.near + self.transparent + self.degenerate + self.outside
    }
}

/// The splatting pass on a headless device: upload, render, read back. For the CLI, tests and
/// benchmarks; the viewer drives a [`Splatter`] on egui's device instead.
pub struct HeadlessRenderer {
    pub gpu: GpuContext,
    pub pipelines: Arc<SplatPipelines>,
    pub splatter: Splatter,
}

impl HeadlessRenderer {
    /// With the rasterizer layout suited to the device ([`RasterTuning::for_device`]).
    pub fn new(gpu: GpuContext) -> Self {
        let tuning = RasterTuning::for_device(&gpu.adapter.get_info(), gpu.device.features());
        Self::with_tuning(gpu, tuning)
    }

    pub fn with_tuning(gpu: GpuContext, tuning: RasterTuning) -> Self {
        Self::with_options(gpu, tuning, FeatureStorage::F32)
    }

    /// With the device's rasterizer layout and features stored as `storage`.
    pub fn with_storage(gpu: GpuContext, storage: FeatureStorage) -> Self {
        let tuning = RasterTuning::for_device(&gpu.adapter.get_info(), gpu.device.features());
        Self::with_options(gpu, tuning, storage)
    }

    pub fn with_options(gpu: GpuContext, tuning: RasterTuning, storage: FeatureStorage) -> Self {
        let pipelines = Arc::new(SplatPipelines::with_storage(&gpu.device, tuning, storage));
        Self::with_pipelines(gpu, pipelines)
    }

    /// Sharing `pipelines`, built for `gpu`'s device, with the other renderers on it.
    pub fn with_pipelines(gpu: GpuContext, pipelines: Arc<SplatPipelines>) -> Self {
        let splatter = Splatter::new(&gpu.device, pipelines.clone());
        Self {
            gpu,
            pipelines,
            splatter,
        }
    }

    /// Uploads `cloud` and renders it; grows the pair buffers and re-renders if a frame overflowed.
    pub fn render(
        &mut self,
        cloud: &GaussianCloud,
        camera: &Camera,
        background: &[f32],
    ) -> Result<(SplatImage, RenderStats), SplatError> {
        let stats = self.draw_cloud(cloud, camera, background)?;
        Ok((self.read_image(camera, background), stats))
    }

    /// Uploads `cloud` and draws it, leaving the image on the GPU (for a refiner there).
    pub fn draw_cloud(
        &mut self,
        cloud: &GaussianCloud,
        camera: &Camera,
        background: &[f32],
    ) -> Result<RenderStats, SplatError> {
        self.check_size(camera)?;
        let (device, queue) = (&self.gpu.device, &self.gpu.queue);
        self.splatter.upload(device, queue, cloud)?;
        Ok(self.draw(camera, background))
    }

    /// Whether the device can draw `camera`'s image.
    fn check_size(&self, camera: &Camera) -> Result<(), SplatError> {
        let max = self.gpu.device.limits().max_texture_dimension_2d;
        let fits = |side| (1..=max).contains(&side);
        if fits(camera.width) && fits(camera.height) {
            Ok(())
        } else {
            Err(SplatError::ImageSize {
                width: camera.width,
                height: camera.height,
                max,
            })
        }
    }

    /// Poses `avatar` on the GPU for `posed` (its body posed) and renders it: the frame path of
    /// the viewer, headless. The avatar's constants go up once per splatter allocation.
    pub fn render_avatar(
        &mut self,
        avatar: &mut GpuAvatar,
        posed: &crate::body::PosedBody,
        camera: &Camera,
        background: &[f32],
    ) -> Result<(SplatImage, RenderStats), AvatarRenderError> {
        let stats = self.draw_avatar(avatar, posed, camera, background)?;
        Ok((self.read_image(camera, background), stats))
    }

    /// [`Self::render_avatar`] leaving the image on the GPU (for a refiner there).
    pub fn draw_avatar(
        &mut self,
        avatar: &mut GpuAvatar,
        posed: &crate::body::PosedBody,
        camera: &Camera,
        background: &[f32],
    ) -> Result<RenderStats, AvatarRenderError> {
        self.check_size(camera)?;
        self.pose_avatar(avatar, posed)?;
        Ok(self.draw(camera, background))
    }

    /// Attaches `avatar`, uploads `posed` and runs the rig pass, leaving the posed Gaussians in
    /// the splatter.
    pub fn pose_avatar(
        &mut self,
        avatar: &mut GpuAvatar,
        posed: &crate::body::PosedBody,
    ) -> Result<(), AvatarRenderError> {
        let (device, queue) = (&self.gpu.device, &self.gpu.queue);
        avatar.attach(device, queue, &mut self.splatter)?;
        avatar.set_pose(queue, posed)?;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("headless rig"),
        });
        avatar.encode(&mut encoder);
        queue.submit([encoder.finish()]);
        Ok(())
    }

    /// Renders the cloud already uploaded (benchmarks upload once and render many times).
    pub fn render_uploaded(
        &mut self,
        camera: &Camera,
        background: &[f32],
    ) -> (SplatImage, RenderStats) {
        let stats = self.draw(camera, background);
        (self.read_image(camera, background), stats)
    }

    /// The image drawn last, read back.
    fn read_image(&self, camera: &Camera, background: &[f32]) -> SplatImage {
        let (device, queue) = (&self.gpu.device, &self.gpu.queue);
        self.splatter
            .read_image(device, queue)
            .unwrap_or_else(|| SplatImage::new(camera.width, camera.height, background.len()))
    }

    /// Renders and waits, returning the stats but leaving the image on the GPU.
    pub fn draw(&mut self, camera: &Camera, background: &[f32]) -> RenderStats {
        loop {
            let (device, queue) = (&self.gpu.device, &self.gpu.queue);
            self.splatter.prepare(device, queue, camera, background);
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("headless splat"),
            });
            self.splatter.encode(&mut encoder, None);
            queue.submit([encoder.finish()]);
            let stats = self.splatter.read_stats(device, queue);
            if !self.splatter.grow_for(device, &stats) {
                if stats.tiles_cut_short > 0 {
                    log::warn!(
                        "{} tiles drawn without their hindmost Gaussians (the CPU adapter's loop \
                         budget; fewer Gaussians per tile, e.g. a larger image, avoid it)",
                        stats.tiles_cut_short
                    );
                }
                return stats;
            }
        }
    }
}

/// Writes a PNG through a temporary file renamed into place (never a half-written image).
pub fn save_png(image: &image::RgbImage, path: &std::path::Path) -> anyhow::Result<()> {
    use anyhow::Context;
    crate::atomic_file::write_atomic(path, |out| {
        image
            .write_to(out, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
    .with_context(|| format!("writing {}", path.display()))
}
