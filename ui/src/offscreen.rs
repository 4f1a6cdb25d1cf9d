//! The viewer's own device, for rendering off screen on a worker thread: an avatar against its
//! photo, and the refined view. The splatting pipelines are built on first use (on the worker
//! that needs them, not while the window opens); one job holds it at a time.

use std::path::Path;

use guava::gpu::GpuContext;
use guava::refine::{Refiner, RefinerOn};
use guava::render::view::{AvatarRef, PoseRef};
use guava::render::{AvatarRenderError, GpuAvatar, HeadlessRenderer, SplatImage};

pub struct OffscreenRenderer {
    gpu: Option<GpuContext>,
    renderer: Option<HeadlessRenderer>,
    /// The last avatar drawn, kept on the GPU (by its viewer id).
    avatar: Option<(u64, GpuAvatar)>,
}

impl OffscreenRenderer {
    pub fn new(gpu: GpuContext) -> Self {
        Self {
            gpu: Some(gpu),
            renderer: None,
            avatar: None,
        }
    }

    pub fn renderer(&mut self) -> &mut HeadlessRenderer {
        if let Some(gpu) = self.gpu.take() {
            self.renderer = Some(HeadlessRenderer::new(gpu));
        }
        self.renderer.as_mut().expect("built above")
    }

    /// `avatar` posed as `pose`, seen by `camera`, on black (`outside`: with the parts its photo
    /// did not show).
    pub fn render_avatar(
        &mut self,
        avatar: &AvatarRef,
        pose: &PoseRef,
        outside: bool,
        camera: &guava::camera::Camera,
    ) -> Result<SplatImage, AvatarRenderError> {
        self.draw_avatar(avatar, pose, outside, camera)?;
        let renderer = self.renderer();
        let (device, queue) = (&renderer.gpu.device, &renderer.gpu.queue);
        Ok(renderer
            .splatter
            .read_image(device, queue)
            .unwrap_or_else(|| SplatImage::new(camera.width, camera.height, 3)))
    }

    /// The same, refined by the avatar's refiner (file `path`, run where `on` says; loaded into
    /// `refiner` if that holds another): a WGSL refiner reads the splat layers on this device.
    pub fn refine_avatar(
        &mut self,
        refiner: &mut Option<Refiner>,
        (path, on): (&Path, RefinerOn),
        avatar: &AvatarRef,
        pose: &PoseRef,
        outside: bool,
        camera: &guava::camera::Camera,
    ) -> Result<SplatImage, String> {
        if refiner
            .as_ref()
            .is_none_or(|r| r.path != path || r.on != on)
        {
            let gpu = &self.renderer().gpu;
            *refiner = Some(Refiner::load_on(on, gpu, path).map_err(|e| e.to_string())?);
        }
        self.draw_avatar(avatar, pose, outside, camera)
            .map_err(|e| e.to_string())?;
        let refiner = refiner.as_mut().expect("loaded above");
        refiner
            .refine_drawn(self.renderer())
            .map_err(|e| e.to_string())
    }

    /// Draws, leaving the image on the GPU.
    fn draw_avatar(
        &mut self,
        avatar: &AvatarRef,
        pose: &PoseRef,
        outside: bool,
        camera: &guava::camera::Camera,
    ) -> Result<(), AvatarRenderError> {
        self.renderer();
        let (Some(renderer), cached) = (&mut self.renderer, &mut self.avatar) else {
            unreachable!("built above");
        };
        let (device, queue) = (&renderer.gpu.device, &renderer.gpu.queue);
        if cached.as_ref().is_none_or(|(id, _)| *id != avatar.id) {
            let gpu = GpuAvatar::new(
                device,
                renderer.pipelines.clone(),
                &avatar.avatar,
                &avatar.triangles,
                avatar.weld.as_deref().map(Vec::as_slice),
            );
            *cached = Some((avatar.id, gpu));
        }
        let (_, gpu) = cached.as_mut().expect("made above");
        gpu.show_outside(queue, outside);
        let background = vec![0.0; avatar.avatar.channels];
        renderer.draw_avatar(gpu, &pose.posed, camera, &background)?;
        Ok(())
    }
}
