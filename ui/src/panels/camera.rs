//! The camera panel: orbit, the source photo's camera, the motion's tracked camera or the keyed
//! path, the orbit's angles, distance and field of view, framing what is shown, and the keys.

use crate::app::GuavaApp;
use crate::orbit::VIEWS;
use crate::viewing::{CameraMode, View};

impl GuavaApp {
    pub(crate) fn camera_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Camera");
        let source = self
            .doc
            .avatar
            .as_ref()
            .and_then(|a| a.source_camera)
            .is_some()
            && self.viewing.view == View::Avatar;
        let tracked = self.doc.motion.as_ref().and_then(|m| m.camera()).is_some()
            && self.viewing.view != View::Gaussians;
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.viewing.camera_mode, CameraMode::Orbit, "orbit");
            ui.add_enabled_ui(source, |ui| {
                ui.selectable_value(
                    &mut self.viewing.camera_mode,
                    CameraMode::Source,
                    "source photo",
                )
                .on_hover_text("the camera of the photo the avatar was reconstructed from");
            });
            ui.add_enabled_ui(tracked, |ui| {
                ui.selectable_value(
                    &mut self.viewing.camera_mode,
                    CameraMode::Tracked,
                    "tracked",
                )
                .on_hover_text("the motion's tracked camera, following the timeline");
            });
            ui.add_enabled_ui(!self.viewing.camera_keys.is_empty(), |ui| {
                ui.selectable_value(&mut self.viewing.camera_mode, CameraMode::Keys, "keys")
                    .on_hover_text("the camera path keyed below, following the timeline");
            });
        });
        let mut moved = false;
        ui.horizontal(|ui| {
            for (i, (name, _)) in VIEWS.iter().enumerate() {
                if ui
                    .button(*name)
                    .on_hover_text(format!("key {}", i + 1))
                    .clicked()
                {
                    self.viewing.preset(i);
                    moved = true;
                }
            }
        });
        let o = &mut self.viewing.orbit;
        let mut yaw = o.yaw_rad.to_degrees();
        let mut pitch = o.pitch_rad.to_degrees();
        let mut fov = o.fov_y_rad.to_degrees();
        moved |= ui
            .add(egui::Slider::new(&mut yaw, -180.0..=180.0).text("yaw °"))
            .changed();
        moved |= ui
            .add(egui::Slider::new(&mut pitch, -88.0..=88.0).text("pitch °"))
            .changed();
        moved |= ui
            .add(egui::Slider::new(&mut fov, 5.0..=120.0).text("fov y °"))
            .changed();
        moved |= ui
            .add(
                egui::Slider::new(&mut o.distance, 0.01..=100.0)
                    .logarithmic(true)
                    .text("distance"),
            )
            .changed();
        ui.horizontal(|ui| {
            let label = ui.label("pan (target)");
            for v in [&mut o.target.x, &mut o.target.y, &mut o.target.z] {
                moved |= ui
                    .add(egui::DragValue::new(v).speed(0.005).max_decimals(3))
                    .labelled_by(label.id)
                    .on_hover_text(
                        "the point the orbit turns around (or drag with the right button)",
                    )
                    .changed();
            }
        });
        o.yaw_rad = yaw.to_radians();
        o.pitch_rad = pitch.to_radians();
        o.fov_y_rad = fov.to_radians();
        if ui.button("Reset camera").clicked() {
            moved = true;
            self.viewing.frame(&mut self.doc);
        }
        let time = self.time();
        egui::CollapsingHeader::new("Camera path (keys)")
            .default_open(false)
            .show(ui, |ui| {
                if let Some(key) = self.viewing.camera_keys.ui(ui, time, self.viewing.orbit) {
                    self.viewing.orbit = key;
                    moved = true;
                }
            });
        if moved {
            self.viewing.camera_mode = CameraMode::Orbit;
        }
    }
}
