//! Keyboard shortcuts, and the help window that lists them with the mouse controls. One table
//! serves both, so the help cannot drift from what the keys do.

use egui::{Key, KeyboardShortcut, Modifiers};

use crate::app::{CameraMode, GuavaApp};
use crate::orbit::VIEWS;

#[derive(Clone, Copy)]
enum Action {
    PlayPause,
    Step(i64),
    Frame,
    View(usize),
    ToggleRefine,
    Open,
    Save,
    Export,
    Help,
    Cancel,
}

const fn key(key: Key) -> KeyboardShortcut {
    KeyboardShortcut::new(Modifiers::NONE, key)
}

const fn command(key: Key) -> KeyboardShortcut {
    KeyboardShortcut::new(Modifiers::COMMAND, key)
}

const SHORTCUTS: [(KeyboardShortcut, &str, Action); 14] = [
    (
        key(Key::Space),
        "play / pause the motion",
        Action::PlayPause,
    ),
    (key(Key::ArrowLeft), "previous frame", Action::Step(-1)),
    (key(Key::ArrowRight), "next frame", Action::Step(1)),
    (
        key(Key::F),
        "frame the avatar (as double-click)",
        Action::Frame,
    ),
    (key(Key::Num1), "front view", Action::View(0)),
    (key(Key::Num2), "three-quarter view", Action::View(1)),
    (key(Key::Num3), "side view", Action::View(2)),
    (key(Key::Num4), "back view", Action::View(3)),
    (key(Key::R), "refiner on / off", Action::ToggleRefine),
    (command(Key::O), "open a file", Action::Open),
    (command(Key::S), "save the avatar", Action::Save),
    (
        command(Key::E),
        "export (PNG, sequence, PLY, glTF)",
        Action::Export,
    ),
    (key(Key::F1), "this help", Action::Help),
    (key(Key::Escape), "cancel the running job", Action::Cancel),
];

const MOUSE: [(&str, &str); 5] = [
    ("drag", "orbit"),
    ("right or middle drag", "pan"),
    ("scroll", "zoom"),
    ("double-click", "frame the avatar"),
    (
        "drop a file",
        "open it (photo, avatar, motion, splats, body)",
    ),
];

impl GuavaApp {
    /// Runs the shortcuts pressed this frame (not while a text field takes the keys).
    pub(crate) fn shortcuts(&mut self, ctx: &egui::Context) {
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        let pressed: Vec<Action> = ctx.input_mut(|i| {
            SHORTCUTS
                .iter()
                .filter(|(s, _, _)| i.consume_shortcut(s))
                .map(|(_, _, a)| *a)
                .collect()
        });
        for action in pressed {
            self.run_shortcut(action);
        }
    }

    fn run_shortcut(&mut self, action: Action) {
        match action {
            Action::PlayPause => {
                if let Some(m) = &mut self.doc.motion {
                    m.toggle_play();
                }
            }
            Action::Step(n) => {
                if let Some(m) = &mut self.doc.motion {
                    m.player.step(n);
                }
            }
            Action::Frame => {
                self.viewing.camera_mode = CameraMode::Orbit;
                self.reset_camera();
            }
            Action::View(i) => self.set_view_preset(i),
            Action::ToggleRefine => self.refined.enabled = !self.refined.enabled,
            Action::Open => self.open_dialog(),
            Action::Save => self.save_avatar_dialog(),
            Action::Export => self.export.open = self.doc.avatar.is_some(),
            Action::Help => self.help = !self.help,
            Action::Cancel => self.cancel_job(),
        }
    }

    /// The orbit at one of [`VIEWS`] (front, three-quarter, side, back), level.
    pub(crate) fn set_view_preset(&mut self, i: usize) {
        self.viewing.orbit.yaw_rad = VIEWS[i].1.to_radians();
        self.viewing.orbit.pitch_rad = 0.0;
        self.viewing.camera_mode = CameraMode::Orbit;
    }

    /// The help window: every shortcut and mouse control.
    pub(crate) fn help_ui(&mut self, ctx: &egui::Context) {
        let mut open = self.help;
        egui::Window::new("Help")
            .open(&mut open)
            .resizable(false)
            .show(ctx, |ui| {
                egui::Grid::new("shortcuts").num_columns(2).show(ui, |ui| {
                    for (shortcut, what, _) in &SHORTCUTS {
                        ui.monospace(ctx.format_shortcut(shortcut));
                        ui.label(*what);
                        ui.end_row();
                    }
                    for (gesture, what) in MOUSE {
                        ui.monospace(gesture);
                        ui.label(what);
                        ui.end_row();
                    }
                });
            });
        self.help = open;
    }
}
