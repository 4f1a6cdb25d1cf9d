//! What the viewport shows: one view, or any two side by side at a split the user drags; and
//! the body's mesh drawn over the avatar. Each side is one pane of the view renderer (the
//! splats presented its own way), the refined picture, the mesh, or the photo.

use guava::render::present::PresentMode;
use guava::view::Display;

/// One view of the viewport's content.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shown {
    /// The avatar's refiner's picture (the raw splat while it is made or while interacting).
    Refined,
    /// The splat's colour channels as they are.
    Raw,
    /// The three feature channels chosen in the display panel.
    Channels,
    Alpha,
    Depth,
    /// The posed body as a mesh.
    Mesh,
    /// The photo the avatar was made from (aligned from its own camera).
    Photo,
}

impl Shown {
    pub const ALL: [Shown; 7] = [
        Shown::Refined,
        Shown::Raw,
        Shown::Channels,
        Shown::Alpha,
        Shown::Depth,
        Shown::Mesh,
        Shown::Photo,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Shown::Refined => "refined",
            Shown::Raw => "raw splat",
            Shown::Channels => "channels",
            Shown::Alpha => "alpha",
            Shown::Depth => "1/depth",
            Shown::Mesh => "mesh",
            Shown::Photo => "photo",
        }
    }

    /// Whether it needs an avatar on a body (a splat file has no refiner, mesh or photo).
    pub fn needs_avatar(self) -> bool {
        matches!(self, Shown::Refined | Shown::Mesh | Shown::Photo)
    }

    /// How the splats are presented for it: `None` where the pane shows no splats.
    pub fn display(self, chosen: &Display) -> Option<Display> {
        let mode = match self {
            Shown::Refined | Shown::Raw | Shown::Channels => PresentMode::Rgb,
            Shown::Alpha => PresentMode::Alpha,
            Shown::Depth => PresentMode::InverseDepth,
            Shown::Mesh | Shown::Photo => return None,
        };
        let rgb_channels = match self {
            Shown::Channels => chosen.rgb_channels,
            _ => [0, 1, 2],
        };
        Some(Display {
            mode,
            rgb_channels,
            inv_depth_range: chosen.inv_depth_range,
        })
    }

    /// The single view the display panel's settings make: its present mode and channels, and
    /// the refined picture where colour is shown and refining is on.
    pub fn of_display(display: &Display, refine: bool) -> Shown {
        match display.mode {
            PresentMode::Alpha => Shown::Alpha,
            PresentMode::InverseDepth => Shown::Depth,
            PresentMode::Rgb if display.rgb_channels != [0, 1, 2] => Shown::Channels,
            PresentMode::Rgb if refine => Shown::Refined,
            PresentMode::Rgb => Shown::Raw,
        }
    }
}

/// Two views split at a share of the viewport's width.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compare {
    pub left: Shown,
    pub right: Shown,
    /// The split, as a share of the width (0–1).
    pub at: f32,
}

impl Default for Compare {
    fn default() -> Self {
        Self {
            left: Shown::Raw,
            right: Shown::Refined,
            at: 0.5,
        }
    }
}

/// The viewport's view settings beyond the display panel's.
#[derive(Clone, Debug, Default)]
pub struct Views {
    /// Two views side by side, when on.
    pub compare: Option<Compare>,
    /// The body's mesh drawn over the avatar at this opacity, when on.
    pub mesh_over: Option<f32>,
}

impl Views {
    pub fn ui(&mut self, ui: &mut egui::Ui, avatar: bool) {
        let mut comparing = self.compare.is_some();
        ui.checkbox(&mut comparing, "compare two views")
            .on_hover_text(
                "two views side by side at a split you drag (in the viewport or here); with the \
             photo on one side the camera goes to the photo's",
            );
        match (comparing, &mut self.compare) {
            (false, c) => *c = None,
            (true, c) => {
                let c = c.get_or_insert_with(Compare::default);
                ui.horizontal(|ui| {
                    choose(ui, "compare_left", &mut c.left, avatar);
                    ui.label("|");
                    choose(ui, "compare_right", &mut c.right, avatar);
                });
                ui.add(
                    egui::Slider::new(&mut c.at, 0.0..=1.0)
                        .show_value(false)
                        .text("split"),
                );
            }
        }
        if avatar {
            let mut over = self.mesh_over.is_some();
            ui.checkbox(&mut over, "the mesh over the avatar")
                .on_hover_text(
                    "the posed body drawn over the avatar (shaded and wireframe as in the Body \
                     panel): how the Gaussians sit on it",
                );
            match (over, &mut self.mesh_over) {
                (false, o) => *o = None,
                (true, o) => {
                    let opacity = o.get_or_insert(0.4);
                    ui.add(egui::Slider::new(opacity, 0.1..=1.0).text("mesh opacity"));
                }
            }
        }
    }
}

fn choose(ui: &mut egui::Ui, id: &str, shown: &mut Shown, avatar: bool) {
    egui::ComboBox::from_id_salt(id)
        .selected_text(shown.name())
        .show_ui(ui, |ui| {
            for s in Shown::ALL
                .into_iter()
                .filter(|s| avatar || !s.needs_avatar())
            {
                ui.selectable_value(shown, s, s.name());
            }
        });
}
