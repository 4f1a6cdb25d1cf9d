//! The central viewport: one egui_wgpu paint callback on egui's own device. The library's
//! [`ViewRenderer`] lives once in `callback_resources`; the frame to draw (content, camera,
//! resolution) rides in the callback value, so the callback only hands it over: `prepare`
//! records whatever changed, `paint` composites.

use std::sync::{Arc, Mutex};

use guava::view::{Frame, ViewRenderer, ViewReport};

pub struct ViewportCallback {
    pub frame: Frame,
    pub report: Arc<Mutex<ViewReport>>,
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
        let Some(view) = resources.get_mut::<ViewRenderer>() else {
            log::error!("viewport resources missing; nothing drawn");
            return Vec::new();
        };
        let mut report = self.report.lock().unwrap_or_else(|e| e.into_inner());
        view.prepare(device, queue, &self.frame, &mut report)
            .into_iter()
            .collect()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        if let Some(view) = resources.get::<ViewRenderer>() {
            view.paint(pass, &self.frame);
        }
    }
}
