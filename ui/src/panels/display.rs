//! The display panel (which channels, alpha or depth; the background; the resolution while
//! interacting) and the frame panel (the HUD): the adapter, the frame's time per pass (pose,
//! rig and encoding on the CPU, each splatting stage on the GPU where it has timestamps, the
//! refiner), whether the frame is refined, the splatting pass's counters and memory.

use guava::refine::RefinerOn;
use guava::render::present::PresentMode;
use guava::render::splatter::Stage;

use crate::app::GuavaApp;
use crate::compare::Shown;
use crate::viewing::{CameraMode, View};

/// Resolution scales offered while the user drags, orbits or plays.
const INTERACTIVE_SCALES: [(f32, &str); 4] =
    [(1.0, "full"), (0.5, "½"), (1.0 / 3.0, "⅓"), (0.25, "¼")];

impl GuavaApp {
    /// The channel count of what the splatting view shows.
    fn shown_channels(&self) -> u32 {
        match (self.viewing.view, &self.doc.scene, &self.doc.avatar) {
            (View::Avatar, _, Some(a)) => a.avatar.channels as u32,
            (View::Gaussians, Some(s), _) => s.cloud.channels as u32,
            _ => 3,
        }
    }

    pub(crate) fn display_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Display");
        let channels = self.shown_channels();
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.viewing.display.mode, PresentMode::Rgb, "Features");
            ui.selectable_value(&mut self.viewing.display.mode, PresentMode::Alpha, "Alpha");
            ui.selectable_value(
                &mut self.viewing.display.mode,
                PresentMode::InverseDepth,
                "1/depth",
            );
        });
        if self.viewing.display.mode == PresentMode::Rgb && channels > 3 {
            ui.horizontal(|ui| {
                let label = ui.label("channels as RGB");
                for c in &mut self.viewing.display.rgb_channels {
                    ui.add(egui::DragValue::new(c).range(0..=channels - 1))
                        .labelled_by(label.id);
                }
            });
        }
        if self.viewing.display.mode == PresentMode::InverseDepth {
            let r = &mut self.viewing.display.inv_depth_range;
            ui.add(
                egui::Slider::new(&mut r[1], 0.01..=10.0)
                    .logarithmic(true)
                    .text("1/depth max"),
            );
        }
        ui.checkbox(&mut self.refined.enabled, "refine when the view settles")
            .on_hover_text(
                "the avatar's refiner turns its splat image into the picture once you stop \
                 dragging or playing (the default refiner, a small network trained on synthetic \
                 subjects, for default reconstructions; GUAVA's, from its networks folder, for \
                 GUAVA-mode avatars); the raw splat image is shown meanwhile",
            );
        ui.add_enabled(
            self.refined.enabled,
            egui::Checkbox::new(
                &mut self.refined.while_interacting,
                "…and while interacting",
            ),
        )
        .on_hover_text(
            "while you drag or play, the latest refined frame stays on screen (behind the view \
             by the refiner's time) and the next is made as soon as the last is done, instead \
             of the raw splat image",
        );
        ui.checkbox(
            &mut self.viewing.display_photo_beside,
            "the photo beside the avatar",
        )
        .on_hover_text(
            "the photo the avatar was made from, left of it; with the camera on the source \
                 photo the two should match (Camera > source photo)",
        );
        let avatar = self.viewing.view == View::Avatar;
        self.viewing.views.ui(ui, avatar);
        let photo = self
            .viewing
            .views
            .compare
            .is_some_and(|c| [c.left, c.right].contains(&Shown::Photo));
        if avatar && photo && self.viewing.camera_mode == CameraMode::Orbit {
            // The photo lines up with the avatar only through its own camera.
            self.viewing.camera_mode = CameraMode::Source;
        }
        ui.add_enabled_ui(self.refined.enabled, |ui| {
            egui::ComboBox::new("refiner_on", "refiner runs on")
                .selected_text(self.refined.on.name())
                .show_ui(ui, |ui| {
                    for on in RefinerOn::ALL {
                        ui.selectable_value(&mut self.refined.on, on, on.name());
                    }
                })
                .response
                .on_hover_text(
                    "auto: our WGSL passes on a hardware GPU (only the refined picture is read \
                     back), ONNX Runtime on the CPU with a software adapter, where it is much \
                     faster, and for GUAVA's refiner, whose operators the passes do not run",
                );
        });
        let refine = self.report().refine;
        if let Some(last) = last_refined(&refine) {
            ui.label(format!("last refined frame: {last}"));
        }
        if let Some(e) = &self.refined.error {
            ui.colored_label(ui.visuals().error_fg_color, format!("refiner off: {e}"));
        }
        if let Some(why) = &self.refined.unavailable {
            ui.colored_label(ui.visuals().warn_fg_color, format!("not refined: {why}"));
        }
        ui.horizontal(|ui| {
            ui.label("background");
            ui.color_edit_button_rgb(&mut self.viewing.background);
        });
        let scale = &mut self.viewing.interaction.scale;
        let current = INTERACTIVE_SCALES
            .iter()
            .find(|(s, _)| s == scale)
            .map_or("?", |(_, name)| name);
        egui::ComboBox::new("interactive_scale", "while interacting")
            .selected_text(current)
            .show_ui(ui, |ui| {
                for (s, name) in INTERACTIVE_SCALES {
                    ui.selectable_value(scale, s, name);
                }
            })
            .response
            .on_hover_text(
                "while you drag, orbit or play, the splatting pass draws at this fraction of the \
                 viewport's resolution, and an avatar as one splat per triangle; at full \
                 quality once input settles",
            );
    }

    pub(crate) fn frame_info_ui(&self, ui: &mut egui::Ui) {
        ui.heading("Frame");
        let report = self.report();
        // Wrapped above the grid: a long adapter name must not widen the side panel (the
        // viewport's size would change under the user).
        ui.label(format!("adapter: {}", self.gpu.adapter));
        egui::Grid::new("hud")
            .num_columns(2)
            .min_col_width(120.0)
            .show(ui, |ui| {
                // Values wrap in the last column: a long one (a slow refine, an engine's name)
                // must not widen the side panel and so resize the viewport under the user.
                let mut row = |k: &str, v: String| {
                    ui.label(k);
                    ui.add(egui::Label::new(egui::RichText::new(v).monospace()).wrap());
                    ui.end_row();
                };
                row("UI frame", format!("{:.1} ms", self.clock.frame_ms));
                for (k, v) in self.drive_hud_rows() {
                    row(k, v);
                }
                if let Some(body) = &self.doc.body {
                    row("pose (CPU)", format!("{:.1} ms", body.pose_ms));
                }
                row("rig + encode (CPU)", format!("{:.1} ms", report.prepare_ms));
                match &report.stage_ms {
                    Some(ms) => {
                        for (stage, ms) in Stage::ALL.iter().zip(ms) {
                            row(&format!("GPU {}", stage.name()), format!("{ms:.2} ms"));
                        }
                        row("GPU splatting", format!("{:.2} ms", ms.iter().sum::<f64>()));
                    }
                    None => row("GPU stages", "no timestamps here".into()),
                }
                if let Some(last) = last_refined(&report.refine) {
                    row("refine (last)", last);
                }
                row(
                    "on screen",
                    match (report.refine.showing, report.refine.behind) {
                        (true, false) => "refined",
                        (true, true) => "refined (an earlier frame)",
                        (false, _) => "raw splat",
                    }
                    .into(),
                );
                row(
                    "splatting memory",
                    format!("{:.1} MiB", report.splat_bytes as f64 / (1u64 << 20) as f64),
                );
                row("splat renders", report.renders.to_string());
                row("rig passes", report.rigs.to_string());
                let [w, h] = report.rendered_size;
                row(
                    "rendered at",
                    format!(
                        "{w}×{h}{}",
                        if self.viewing.interaction.active {
                            " (interacting)"
                        } else {
                            ""
                        }
                    ),
                );
                if let Some(s) = report.stats {
                    row("Gaussians", s.input.to_string());
                    if let Some(a) = self.doc.avatar.as_ref().filter(|a| !a.show_outside) {
                        row("left out (unseen)", a.avatar.outside.to_string());
                    }
                    row("drawn", s.visible.to_string());
                    row("culled: near", s.near.to_string());
                    row("culled: off-screen", s.outside.to_string());
                    row("culled: transparent", s.transparent.to_string());
                    row("dropped: NaN/Inf", s.nonfinite.to_string());
                    row("degenerate", s.degenerate.to_string());
                    row("tile pairs", s.tile_pairs.to_string());
                    if s.tiles_cut_short > 0 {
                        row("tiles cut short", s.tiles_cut_short.to_string());
                    }
                }
            });
    }
}

/// Where the last refined picture was made and how long it took to reach the screen.
fn last_refined(refine: &guava::view::RefineReport) -> Option<String> {
    let engine = refine.engine.as_ref()?;
    Some(match refine.ms {
        Some(ms) => format!("{ms:.0} ms, {engine}"),
        None => format!("{engine}, recorded with the frame"),
    })
}
