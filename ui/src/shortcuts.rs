//! Keyboard shortcuts, and the help window that lists them with the mouse controls. One table
//! serves both, so the help cannot drift from what the keys do. The keys pressed come out as
//! [`Shortcut`] messages, which the app carries out.

use egui::{Key, KeyboardShortcut, Modifiers};

/// What a shortcut asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shortcut {
    PlayPause,
    Step(i64),
    Frame,
    /// One of [`crate::orbit::VIEWS`].
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

const SHORTCUTS: [(KeyboardShortcut, &str, Shortcut); 14] = [
    (
        key(Key::Space),
        "play / pause the motion",
        Shortcut::PlayPause,
    ),
    (key(Key::ArrowLeft), "previous frame", Shortcut::Step(-1)),
    (key(Key::ArrowRight), "next frame", Shortcut::Step(1)),
    (
        key(Key::F),
        "frame the avatar (as double-click)",
        Shortcut::Frame,
    ),
    (key(Key::Num1), "front view", Shortcut::View(0)),
    (key(Key::Num2), "three-quarter view", Shortcut::View(1)),
    (key(Key::Num3), "side view", Shortcut::View(2)),
    (key(Key::Num4), "back view", Shortcut::View(3)),
    (key(Key::R), "refiner on / off", Shortcut::ToggleRefine),
    (command(Key::O), "open a file", Shortcut::Open),
    (command(Key::S), "save the avatar", Shortcut::Save),
    (
        command(Key::E),
        "export (PNG, sequence, PLY, glTF)",
        Shortcut::Export,
    ),
    (key(Key::F1), "this help", Shortcut::Help),
    (key(Key::Escape), "cancel the running job", Shortcut::Cancel),
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

/// The shortcuts pressed this frame (none while a text field takes the keys).
pub fn pressed(ctx: &egui::Context) -> Vec<Shortcut> {
    if ctx.egui_wants_keyboard_input() {
        return Vec::new();
    }
    ctx.input_mut(|i| {
        SHORTCUTS
            .iter()
            .filter(|(s, _, _)| i.consume_shortcut(s))
            .map(|(_, _, a)| *a)
            .collect()
    })
}

/// The help window: every shortcut and mouse control (`open`: whether it shows).
pub fn help_window(ctx: &egui::Context, open: &mut bool) {
    egui::Window::new("Help")
        .open(open)
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
}
