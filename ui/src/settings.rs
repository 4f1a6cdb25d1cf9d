//! What the viewer remembers between runs (eframe's storage; nothing in tests, which have none):
//! the look (background, refiner on or off, resolution while interacting, field of view), the
//! export settings and the files opened recently.

use std::path::PathBuf;

use crate::exports::{CameraPath, ExportSettings};
use crate::refined::RefinedView;
use crate::viewing::Viewing;

const KEY: &str = "guava-rs settings";
/// Recent files kept, newest first.
pub const RECENT: usize = 8;

#[derive(serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct Settings {
    background: [f32; 3],
    refine: bool,
    refine_while_interacting: bool,
    refiner_on: guava::refine::RefinerOn,
    interactive_scale: Option<f32>,
    fov_deg: f32,
    export_size: [u32; 2],
    export_fps: f32,
    export_gif: bool,
    export_mp4: bool,
    export_turntable: bool,
    recent: Vec<PathBuf>,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            background: [0.0; 3],
            refine: true,
            refine_while_interacting: false,
            refiner_on: guava::refine::RefinerOn::Auto,
            interactive_scale: None,
            fov_deg: 50.0,
            export_size: [1024, 1024],
            export_fps: 30.0,
            export_gif: true,
            export_mp4: true,
            export_turntable: false,
            recent: Vec::new(),
        }
    }
}

/// Files opened recently, newest first.
#[derive(Default)]
pub struct Recent(Vec<PathBuf>);

impl Recent {
    /// Puts `path` first.
    pub fn remember(&mut self, path: PathBuf) {
        self.0.retain(|p| *p != path);
        self.0.insert(0, path);
        self.0.truncate(RECENT);
    }

    pub fn files(&self) -> &[PathBuf] {
        &self.0
    }
}

/// What the settings are read from and put back on: the parts of the app that remember.
pub struct Remembered<'a> {
    pub viewing: &'a mut Viewing,
    pub refined: &'a mut RefinedView,
    pub export: &'a mut ExportSettings,
    pub recent: &'a mut Recent,
}

impl Settings {
    pub fn load(storage: &dyn eframe::Storage) -> Option<Self> {
        eframe::get_value(storage, KEY)
    }

    pub fn save(app: Remembered, storage: &mut dyn eframe::Storage) {
        let e = &app.export;
        let settings = Self {
            background: app.viewing.background,
            refine: app.refined.enabled,
            refine_while_interacting: app.refined.while_interacting,
            refiner_on: app.refined.on,
            interactive_scale: Some(app.viewing.interaction.scale),
            fov_deg: app.viewing.orbit.fov_y_rad.to_degrees(),
            export_size: [e.width, e.height],
            export_fps: e.fps,
            export_gif: e.gif,
            export_mp4: e.mp4,
            export_turntable: e.path == CameraPath::Turntable,
            recent: app.recent.0.clone(),
        };
        eframe::set_value(storage, KEY, &settings);
    }

    /// Puts the remembered values back (values out of range are left as they are).
    pub fn apply(self, app: Remembered) {
        if self.background.iter().all(|c| (0.0..=1.0).contains(c)) {
            app.viewing.background = self.background;
        }
        app.refined.enabled = self.refine;
        app.refined.while_interacting = self.refine_while_interacting;
        app.refined.on = self.refiner_on;
        if let Some(s) = self.interactive_scale.filter(|s| *s > 0.0 && *s <= 1.0) {
            app.viewing.interaction.scale = s;
        }
        if self.fov_deg > 1.0 && self.fov_deg < 170.0 {
            app.viewing.orbit.fov_y_rad = self.fov_deg.to_radians();
        }
        let e = app.export;
        let [w, h] = self.export_size;
        if (16..=8192).contains(&w) && (16..=8192).contains(&h) {
            (e.width, e.height) = (w, h);
        }
        if self.export_fps >= 1.0 && self.export_fps <= 120.0 {
            e.fps = self.export_fps;
        }
        e.gif = self.export_gif;
        e.mp4 = self.export_mp4;
        if self.export_turntable {
            e.path = CameraPath::Turntable;
        }
        app.recent.0 = self.recent.into_iter().take(RECENT).collect();
    }
}
