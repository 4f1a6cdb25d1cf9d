//! Rendering off screen on a worker thread, on the viewer's device with the view's splatting
//! pipelines: exports (the avatar as on screen, at any size) and an avatar against its photo.
//! One job holds it at a time.

use std::path::Path;
use std::sync::Arc;

use guava::gpu::GpuContext;
use guava::refine::{Refiner, RefinerOn};
use guava::render::{AvatarRenderError, GpuAvatar, HeadlessRenderer, SplatImage, SplatPipelines};
use guava::view::{AvatarRef, PoseRef};

pub struct OffscreenRenderer {
    pub renderer: HeadlessRenderer,
    /// The avatar an export is drawing, kept on the GPU between its frames (by its viewer id)
    /// and let go when the export ends ([`Self::release`]).
    avatar: Option<(u64, GpuAvatar)>,
}

impl OffscreenRenderer {
    pub fn new(gpu: GpuContext, pipelines: Arc<SplatPipelines>) -> Self {
        Self {
            renderer: HeadlessRenderer::with_pipelines(gpu, pipelines),
            avatar: None,
        }
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
        let renderer = &self.renderer;
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
            let gpu = &self.renderer.gpu;
            *refiner = Some(Refiner::load_on(on, gpu, path).map_err(|e| e.to_string())?);
        }
        self.draw_avatar(avatar, pose, outside, camera)
            .map_err(|e| e.to_string())?;
        let refiner = refiner.as_mut().expect("loaded above");
        refiner
            .refine_drawn(&self.renderer)
            .map_err(|e| e.to_string())
    }

    /// Lets go of the avatar an export drew (its copy on the GPU).
    pub fn release(&mut self) {
        self.avatar = None;
    }

    /// Draws, leaving the image on the GPU.
    fn draw_avatar(
        &mut self,
        avatar: &AvatarRef,
        pose: &PoseRef,
        outside: bool,
        camera: &guava::camera::Camera,
    ) -> Result<(), AvatarRenderError> {
        let renderer = &mut self.renderer;
        let (device, queue) = (&renderer.gpu.device, &renderer.gpu.queue);
        if self.avatar.as_ref().is_none_or(|(id, _)| *id != avatar.id) {
            let gpu = avatar.upload(device, renderer.pipelines.clone(), &avatar.avatar);
            self.avatar = Some((avatar.id, gpu));
        }
        let (_, gpu) = self.avatar.as_mut().expect("made above");
        gpu.show_outside(queue, outside);
        let background = vec![0.0; avatar.avatar.channels];
        renderer.draw_avatar(gpu, &pose.posed, camera, &background)?;
        Ok(())
    }
}
