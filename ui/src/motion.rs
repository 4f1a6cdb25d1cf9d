//! The loaded motion driving the body: its tracking, how it maps onto the current body, the
//! playback clock, and the timeline (play/pause, step, loop, speed, scrub) with what could not be
//! carried over.

use std::sync::Arc;

use guava::body::{BodyPose, Posable};
use guava::tracking::import::Imported;
use guava::tracking::{Player, Retarget, Tracking};

/// Playback speeds offered in the timeline.
const SPEEDS: [f32; 6] = [0.25, 0.5, 1.0, 1.5, 2.0, 4.0];
/// Longest wall-clock step the clock takes in one UI frame, so a stall does not skip motion.
const MAX_STEP_S: f64 = 0.25;

pub struct Motion {
    /// What it is and where it came from, shown above the timeline.
    pub label: String,
    tracking: Arc<Tracking>,
    retarget: Retarget,
    pub player: Player,
    /// Import notes and what the current body cannot take, shown to the user.
    notes: Vec<String>,
    import_notes: Vec<String>,
    /// The clock time last written into the pose (`None`: write on the next update).
    sampled_at: Option<f64>,
    /// What a layered motion is layered on: the pose as the next update finds it after a new
    /// avatar or body (the photo's pose).
    base: Option<BodyPose>,
}

impl Motion {
    pub fn new(label: String, imported: Imported, model: &impl Posable) -> Self {
        let tracking = Arc::new(imported.tracking);
        let retarget = Retarget::new(&tracking, model);
        let mut motion = Self {
            label,
            player: Player::new(&tracking),
            tracking,
            retarget,
            notes: Vec::new(),
            import_notes: imported.notes,
            sampled_at: None,
            base: None,
        };
        motion.refresh_notes();
        motion
    }

    /// Maps the same motion onto another body (the time and play state stay).
    pub fn retarget_to(&mut self, model: &impl Posable) {
        self.retarget = Retarget::new(&self.tracking, model);
        self.refresh_notes();
        self.resample();
    }

    /// Writes the pose again on the next update (the pose was replaced underneath: a new
    /// avatar's photo pose, which a layered motion is then layered on).
    pub fn resample(&mut self) {
        self.sampled_at = None;
        self.base = None;
    }

    fn refresh_notes(&mut self) {
        self.notes = self.import_notes.clone();
        self.notes.extend(self.retarget.report.lines());
    }

    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// The tracked camera at the current time (world→camera in OpenCV axes, `invtanfov`), when
    /// the motion has cameras.
    pub fn camera(&self) -> Option<(glam::Mat4, f32)> {
        guava::tracking::camera_at(&self.tracking, self.player.time())
    }

    /// The tracking and its mapping onto the body, to pose frames elsewhere (an export).
    pub fn sampler(&self) -> (Arc<Tracking>, Retarget) {
        (self.tracking.clone(), self.retarget.clone())
    }

    /// Play or pause; playing a finished, unlooped motion starts it over.
    pub fn toggle_play(&mut self) {
        toggle(&mut self.player);
    }

    pub fn is_playing(&self) -> bool {
        self.player.playing
    }

    /// Advances the clock by `dt` seconds and writes the pose when the time moved (or was never
    /// written). Returns whether the pose was written.
    pub fn update(&mut self, dt: f64, pose: &mut BodyPose) -> bool {
        self.player.advance(dt.clamp(0.0, MAX_STEP_S));
        let time = self.player.time();
        if self.sampled_at == Some(time) {
            return false;
        }
        if self.tracking.layered {
            let base = self.base.get_or_insert_with(|| pose.clone());
            self.retarget.restore(base, pose);
        }
        self.retarget.sample(&self.tracking, time, pose);
        self.sampled_at = Some(time);
        true
    }

    /// The timeline controls.
    pub fn timeline_ui(&mut self, ui: &mut egui::Ui) {
        let p = &mut self.player;
        ui.horizontal(|ui| {
            if ui
                .button("< Frame")
                .on_hover_text("Previous frame")
                .clicked()
            {
                p.step(-1);
            }
            let label = if p.playing { "Pause" } else { "Play" };
            if ui.button(label).on_hover_text("Space").clicked() {
                toggle(p);
            }
            if ui.button("Frame >").on_hover_text("Next frame").clicked() {
                p.step(1);
            }
            ui.checkbox(&mut p.looping, "loop");
            egui::ComboBox::new("speed", "speed")
                .selected_text(format!("{}×", p.speed))
                .width(60.0)
                .show_ui(ui, |ui| {
                    for s in SPEEDS {
                        ui.selectable_value(&mut p.speed, s, format!("{s}×"));
                    }
                });
            ui.monospace(format!(
                "frame {}/{} · {:.2} / {:.2} s",
                p.frame() + 1,
                p.frame_count(),
                p.time(),
                p.duration()
            ));
        });
        let mut time = p.time();
        let width = ui.available_width();
        ui.spacing_mut().slider_width = (width - 50.0).max(50.0);
        let scrub = ui.add(
            egui::Slider::new(&mut time, 0.0..=p.duration().max(1e-6))
                .show_value(false)
                .text("time"),
        );
        if scrub.changed() {
            p.playing = false;
            p.seek(time);
        }
    }

    /// The motion's description and its notes (what was not applied), for the side panel.
    pub fn info_ui(&self, ui: &mut egui::Ui) {
        ui.label(&self.label);
        ui.label(format!(
            "drives {} joints and {} parameters of this body",
            self.retarget.report.joints_mapped, self.retarget.report.parameters_mapped
        ));
        for note in &self.notes {
            ui.colored_label(ui.visuals().warn_fg_color, note);
        }
    }
}

fn toggle(p: &mut Player) {
    if !p.playing && !p.looping && p.time() >= p.duration() {
        p.seek(0.0);
    }
    p.playing = !p.playing;
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Quat, Vec3};
    use guava::body::BodyModel;

    /// The viewer's pose persists from frame to frame, and the demo motion is layered on the
    /// photo's pose: each update layers it on the base once (not on the last frame's pose), and
    /// after the pose is replaced underneath (a new avatar, the *Rest pose* button) it layers on
    /// the new one.
    #[test]
    fn a_layered_motion_layers_on_the_pose_it_found_once() {
        let body = BodyModel::default_body().expect("default body");
        let tracking = guava::tracking::demo_motion().expect("demo motion");
        assert!(tracking.layered);
        let imported = Imported {
            tracking,
            notes: Vec::new(),
        };
        let mut motion = Motion::new("demo".into(), imported, &body);
        motion.player.playing = false;
        let head = body.joint_index("head").expect("head");
        let turn = |pose: &BodyPose| Quat::from_scaled_axis(pose.rotations[head]);
        // The angle between two rotations, accurate near zero (unlike an acos of their dot).
        let apart = |a: Quat, b: Quat| 2.0 * (a.inverse() * b).xyz().length();
        let mut photo = BodyPose::rest(&body);
        photo.rotations[head] = Vec3::new(0.1, 0.4, 0.0);
        let mut pose = photo.clone();
        motion.player.seek(3.6);
        assert!(motion.update(0.0, &mut pose));
        let on_photo = turn(&pose);
        assert!(apart(on_photo, turn(&photo)) > 0.05, "the head moves");
        // Back and forth in time: the same pose at the same time, nothing piled up.
        motion.player.seek(5.5);
        motion.update(0.0, &mut pose);
        motion.player.seek(3.6);
        motion.update(0.0, &mut pose);
        assert!(apart(turn(&pose), on_photo) < 1e-5);
        // The pose put to rest underneath: the motion layers on rest from then on.
        pose = BodyPose::rest(&body);
        motion.resample();
        motion.update(0.0, &mut pose);
        let on_rest = turn(&pose);
        let expected = turn(&photo).inverse() * on_photo;
        assert!(apart(on_rest, expected) < 1e-5, "{on_rest:?} {expected:?}");
    }
}
