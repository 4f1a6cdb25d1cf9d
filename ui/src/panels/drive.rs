//! The *Drive* menu and panel: driving the body live from a video or a webcam
//! ([`crate::drive`]), the driving video in a corner of the viewport, and recording what was
//! tracked.

use std::path::PathBuf;

use crate::app::GuavaApp;
use crate::drive::{Drive, DriveSource};

/// The clip shipped for trying live driving.
pub fn demo_video() -> PathBuf {
    PathBuf::from(guava::video::DEMO_VIDEO)
}

/// What the menu says when the webcam is not built in.
#[cfg(not(feature = "webcam"))]
const NO_WEBCAM: &str = "this viewer was built without the `webcam` cargo feature: \
                         cargo run --release --features webcam (Linux needs libclang-dev to build \
                         it and a V4L2 camera)";

impl GuavaApp {
    /// Drives the body from `source` (stopping any drive before), pausing the timeline.
    pub fn drive_from(&mut self, source: DriveSource) {
        self.drive = None;
        if let Some(motion) = &mut self.doc.motion {
            motion.player.playing = false;
        }
        let drive = Drive::start(source);
        self.info(format!("driving from the {}", drive.label));
        self.drive = Some(drive);
    }

    /// Stops driving; the body keeps the last pose.
    pub fn stop_driving(&mut self) {
        if let Some(drive) = self.drive.take() {
            self.info(format!("stopped driving from the {}", drive.label));
        }
    }

    pub fn driving(&self) -> Option<&Drive> {
        self.drive.as_ref()
    }

    pub(crate) fn drive_menu_ui(&mut self, ui: &mut egui::Ui) {
        if ui
            .button("From video…")
            .on_hover_text("an MP4 or MOV file with H.264 video, tracked live as it plays")
            .clicked()
        {
            if let Some(path) = rfd::FileDialog::new()
                .add_filter("Video (H.264)", &["mp4", "mov", "m4v"])
                .pick_file()
            {
                self.drive_from(DriveSource::File(path));
            }
            ui.close();
        }
        if ui
            .button("From the demo video")
            .on_hover_text("a short Pexels clip shipped with the viewer")
            .clicked()
        {
            self.drive_from(DriveSource::File(demo_video()));
            ui.close();
        }
        #[cfg(feature = "webcam")]
        if ui.button("From webcam").clicked() {
            self.drive_from(DriveSource::Webcam(0));
            ui.close();
        }
        #[cfg(not(feature = "webcam"))]
        ui.add_enabled(false, egui::Button::new("From webcam"))
            .on_disabled_hover_text(NO_WEBCAM);
        ui.separator();
        if ui
            .add_enabled(self.drive.is_some(), egui::Button::new("Stop driving"))
            .clicked()
        {
            self.stop_driving();
            ui.close();
        }
    }

    /// The panel's section: what drives the body, how far behind it is, recording.
    pub(crate) fn drive_ui(&mut self, ui: &mut egui::Ui) {
        let Some(drive) = &self.drive else {
            return;
        };
        ui.heading("Driving");
        ui.label(&drive.label);
        let running = drive.running();
        match drive.message() {
            Some((text, true)) => {
                ui.colored_label(ui.visuals().error_fg_color, text);
            }
            Some((text, false)) => {
                ui.label(text);
            }
            None if !running => {
                ui.label("the video has ended; the body keeps its last pose");
            }
            None => {}
        }
        let mut recording = drive.recording();
        ui.horizontal(|ui| {
            if ui
                .checkbox(&mut recording, "record")
                .on_hover_text("keep every solve, to save as a tracking file")
                .changed()
            {
                drive.set_recording(recording);
            }
            ui.label(format!("{} solves", drive.recorded()));
        });
        let mut save = false;
        let mut stop = false;
        ui.horizontal(|ui| {
            save = ui
                .add_enabled(
                    drive.recorded() > 0,
                    egui::Button::new("Save recording as…"),
                )
                .clicked();
            stop = ui.button("Stop").clicked();
        });
        if save {
            self.save_recording_dialog();
        }
        if stop {
            self.stop_driving();
        }
    }

    fn save_recording_dialog(&mut self) {
        let Some(tracking) = self.drive.as_ref().and_then(Drive::recording_as_tracking) else {
            return;
        };
        let Some(path) = rfd::FileDialog::new()
            .add_filter("Tracking", &["json"])
            .set_file_name("recorded.json")
            .save_file()
        else {
            return;
        };
        match tracking.save(&path) {
            Ok(()) => self.info(format!(
                "recorded {} frames → {}",
                tracking.frames.len(),
                path.display()
            )),
            Err(e) => self.error(e.to_string()),
        }
    }

    /// The HUD's rows for a drive: the solve's time, solves a second, frames behind.
    pub(crate) fn drive_hud_rows(&self) -> Vec<(&'static str, String)> {
        let Some(drive) = &self.drive else {
            return Vec::new();
        };
        let (solve_ms, rate) = drive.rates();
        vec![
            (
                "drive: solve",
                format!("{solve_ms:.0} ms, {rate:.1} a second"),
            ),
            (
                "drive: latency",
                drive
                    .latency_frames()
                    .map_or("—".into(), |n| format!("{n} frames behind the video")),
            ),
        ]
    }

    /// The driving video in the viewport's top-right corner, a quarter of its width.
    pub(crate) fn drive_picture_ui(&mut self, ui: &mut egui::Ui, viewport: egui::Rect) {
        let ctx = ui.ctx().clone();
        let Some(texture) = self.drive.as_mut().and_then(|d| d.picture(&ctx)) else {
            return;
        };
        let size = texture.size_vec2();
        let width = (viewport.width() * 0.25).max(80.0);
        let height = width * size.y / size.x.max(1.0);
        let rect = egui::Rect::from_min_size(
            egui::pos2(viewport.right() - width - 8.0, viewport.top() + 8.0),
            egui::vec2(width, height),
        );
        let painter = ui.painter_at(viewport);
        painter.image(
            texture.id(),
            rect,
            egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
            egui::Color32::WHITE,
        );
        painter.rect_stroke(
            rect,
            2.0,
            egui::Stroke::new(1.0, egui::Color32::from_gray(200)),
            egui::StrokeKind::Outside,
        );
    }
}
