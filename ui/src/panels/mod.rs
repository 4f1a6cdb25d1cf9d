//! The window's panels, one file each: the menu and status bar here, the side panel's sections
//! (avatar, mode, camera, display and frame) and the viewport in their own files.

mod avatar;
mod camera;
mod display;
mod drive;
mod mode;
mod viewport;

use crate::app::GuavaApp;
use crate::files::demo_portrait;
use crate::viewing::View;
pub use drive::demo_video;

impl GuavaApp {
    pub(crate) fn menu_ui(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open…").on_hover_text("Ctrl+O").clicked() {
                    self.open_dialog();
                    ui.close();
                }
                ui.add_enabled_ui(!self.recent.files().is_empty(), |ui| {
                    ui.menu_button("Open recent", |ui| {
                        let mut chosen = None;
                        for path in self.recent.files() {
                            if ui.button(path.display().to_string()).clicked() {
                                chosen = Some(path.clone());
                            }
                        }
                        if let Some(path) = chosen {
                            self.open(path);
                            ui.close();
                        }
                    });
                });
                if ui.button("Open GUAVA networks folder…").clicked() {
                    if let Some(dir) = rfd::FileDialog::new().pick_folder() {
                        self.open(dir);
                    }
                    ui.close();
                }
                if ui.button("Open test scene").clicked() {
                    self.open_test_scene();
                    ui.close();
                }
                if ui.button("Reconstruct demo portrait").clicked() {
                    self.open(demo_portrait());
                    ui.close();
                }
                if ui.button("Reconstruct synthetic photo").clicked() {
                    self.reconstruct_synthetic_photo();
                    ui.close();
                }
                if ui
                    .add_enabled(self.doc.scene.is_some(), egui::Button::new("Save PLY as…"))
                    .clicked()
                {
                    self.save_ply_dialog();
                    ui.close();
                }
                if ui
                    .add_enabled(self.doc.avatar.is_some(), egui::Button::new("Save avatar as…"))
                    .clicked()
                {
                    self.save_avatar_dialog();
                    ui.close();
                }
                if ui
                    .add_enabled(self.doc.avatar.is_some(), egui::Button::new("Export…"))
                    .on_hover_text("the view as PNG, the timeline as a PNG sequence and GIF, the posed avatar as PLY, the posed mesh as glTF")
                    .clicked()
                {
                    self.export.open = true;
                    ui.close();
                }
                ui.separator();
                if ui.button("Quit").clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("Drive", |ui| self.drive_menu_ui(ui));
            ui.menu_button("View", |ui| {
                self.view_choice_ui(ui);
                ui.separator();
                if ui.button("Reset camera").clicked() {
                    self.viewing.frame(&mut self.doc);
                    ui.close();
                }
            });
            ui.menu_button("Help", |ui| {
                if ui.button("Shortcuts and mouse").on_hover_text("F1").clicked() {
                    self.help = true;
                    ui.close();
                }
            });
        });
    }

    /// Picks a file to open.
    pub(crate) fn open_dialog(&mut self) {
        if let Some(path) = rfd::FileDialog::new()
            .add_filter(
                "Splats (PLY, .splat), body template, avatar, photo or motion",
                &[
                    "ply", "splat", "glb", "guava", "png", "jpg", "jpeg", "json", "csv", "npz",
                ],
            )
            .pick_file()
        {
            self.open(path);
        }
    }

    pub(crate) fn save_avatar_dialog(&mut self) {
        if self.doc.avatar.is_none() {
            return;
        }
        if let Some(path) = rfd::FileDialog::new()
            .add_filter("guava-rs avatar", &["guava"])
            .set_file_name(format!("{}.guava", self.doc.avatar_stem()))
            .save_file()
        {
            // The outcome is in the status bar.
            let _ = self.save_avatar(&path);
        }
    }

    fn save_ply_dialog(&mut self) {
        let Some(scene) = &self.doc.scene else { return };
        if let Some(path) = rfd::FileDialog::new()
            .add_filter("3DGS PLY", &["ply"])
            .set_file_name(format!("{}.ply", scene.name))
            .save_file()
        {
            let _ = self.report_result(self.doc.save_scene(&path));
        }
    }

    /// The running job with its stage and Cancel, else the last message.
    pub(crate) fn status_ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            if let Some(job) = self.jobs.running() {
                ui.spinner();
                ui.label(format!(
                    "{} — {} ({:.1} s)",
                    job.path.display(),
                    job.stage(),
                    job.started.elapsed().as_secs_f32()
                ));
                if ui.button("Cancel").clicked() {
                    self.cancel_job();
                    return;
                }
                ui.ctx().request_repaint();
            } else if let Some((text, is_error)) = &self.status {
                let color = if *is_error {
                    ui.visuals().error_fg_color
                } else {
                    ui.visuals().text_color()
                };
                ui.colored_label(color, text);
            }
        });
    }

    pub(crate) fn view_choice_ui(&mut self, ui: &mut egui::Ui) {
        let mut view = self.viewing.view;
        ui.selectable_value(&mut view, View::Body, "Body mesh");
        ui.selectable_value(&mut view, View::Gaussians, "Gaussians");
        if self.doc.avatar.is_some() {
            ui.selectable_value(&mut view, View::Avatar, "Avatar");
        }
        self.set_view(view);
    }

    /// The side panel: the view, then what is shown (avatar, mode, body, motion, scene), then
    /// how (camera, display) and the frame's counters.
    pub(crate) fn side_panel_ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.label("View");
            self.view_choice_ui(ui);
        });
        ui.separator();
        if self.viewing.view == View::Avatar {
            self.avatar_ui(ui);
        }
        if matches!(self.viewing.view, View::Body | View::Avatar) {
            self.mode_ui(ui);
            ui.separator();
            ui.heading("Body");
            match &mut self.doc.body {
                Some(body) => {
                    if body.ui(ui)
                        && let Some(motion) = &mut self.doc.motion
                    {
                        motion.resample();
                    }
                }
                None => {
                    ui.label("no body model loaded");
                }
            }
            ui.separator();
            self.drive_ui(ui);
            self.motion_ui(ui);
            ui.separator();
        }
        ui.heading("Scene");
        match &self.doc.scene {
            Some(s) => {
                ui.label(format!("{} — {}", s.name, s.kind));
                ui.label(format!(
                    "{} Gaussians · {} channels",
                    s.cloud.len(),
                    s.cloud.channels
                ));
            }
            None => {
                ui.label("nothing loaded");
            }
        }
        ui.separator();
        self.camera_ui(ui);
        ui.separator();
        self.display_ui(ui);
        ui.separator();
        self.frame_info_ui(ui);
        egui::CollapsingHeader::new("Error against time (guava report)")
            .default_open(false)
            .show(ui, |ui| {
                self.report_plot
                    .get_or_insert_with(|| {
                        crate::report_plot::ReportPlot::read(
                            &crate::report_plot::committed_report(),
                        )
                    })
                    .ui(ui);
            });
    }

    fn motion_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Motion");
        match &self.doc.motion {
            Some(motion) => {
                motion.info_ui(ui);
                if ui.button("Unload motion").clicked() {
                    self.doc.motion = None;
                }
            }
            None => {
                ui.label("none: open a tracking .json, ARKit .csv or SMPL-X .npz");
            }
        }
    }
}
