//! How faithful a new avatar is to its photo, for the avatar panel: the avatar rendered from its
//! photo's camera through the frame path (on the viewer's own device, on the reconstruction's
//! worker thread), the photo, their difference, and `guava eval`'s metrics — so a user sees at
//! once how close the avatar is, and whether adjusting the fit helped.

use guava::avatar::Avatar;
use guava::body::Posable;
use guava::eval::{EvalError, Metrics};
use guava::photo::SourceImage;
use guava::tracking::SourceView;

use crate::offscreen::OffscreenRenderer;

/// `avatar` on `body` seen as `view` saw `photo`, compared with it (`guava eval`).
pub fn measure(
    offscreen: &mut OffscreenRenderer,
    avatar: &Avatar,
    body: &impl Posable,
    view: &SourceView,
    photo: &SourceImage,
) -> Result<Fidelity, EvalError> {
    let renderer = &mut offscreen.renderer;
    let (metrics, rendered) = guava::eval::evaluate(renderer, avatar, body, Some(view), photo)?;
    let strip = guava::eval::side_by_side(photo, &rendered);
    let size = [strip.width() as usize, strip.height() as usize];
    Ok(Fidelity {
        metrics,
        before: None,
        strip: egui::ColorImage::from_rgb(size, strip.as_raw()),
        texture: None,
        shown: Shown::Avatar,
    })
}

/// Which third of the strip the panel shows.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Shown {
    Photo,
    Avatar,
    Difference,
}

impl Shown {
    const ALL: [(Self, &'static str, &'static str); 3] = [
        (
            Self::Photo,
            "photo",
            "the photo × its person mask, as the avatar saw it",
        ),
        (
            Self::Avatar,
            "avatar",
            "the avatar rendered from the photo's camera, through the frame path",
        ),
        (
            Self::Difference,
            "difference ×4",
            "|avatar − photo|, four times brighter so that small errors show",
        ),
    ];

    fn third(self) -> f32 {
        match self {
            Self::Photo => 0.0,
            Self::Avatar => 1.0,
            Self::Difference => 2.0,
        }
    }
}

/// An avatar next to its photo.
pub struct Fidelity {
    pub metrics: Metrics,
    /// The previous avatar's metrics on the same photo (after adjusting the fit).
    pub before: Option<Metrics>,
    /// The photo, the render and their difference side by side (uploaded once).
    strip: egui::ColorImage,
    texture: Option<egui::TextureHandle>,
    shown: Shown,
}

impl Fidelity {
    /// The photo (masked, at the size it was compared at) as a texture, and the part of the
    /// texture it fills.
    pub fn photo(&mut self, ctx: &egui::Context) -> (egui::TextureId, egui::Rect) {
        let texture = self.texture(ctx);
        let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0 / 3.0, 1.0));
        (texture, uv)
    }

    fn texture(&mut self, ctx: &egui::Context) -> egui::TextureId {
        self.texture
            .get_or_insert_with(|| {
                ctx.load_texture(
                    "photo | avatar | difference",
                    self.strip.clone(),
                    Default::default(),
                )
            })
            .id()
    }

    pub fn ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            for (shown, name, hover) in Shown::ALL {
                ui.selectable_value(&mut self.shown, shown, name)
                    .on_hover_text(hover);
            }
        });
        let texture = self.texture(ui.ctx());
        let side = ui.available_width().min(320.0);
        let third = self.shown.third();
        let uv = egui::Rect::from_min_max(
            egui::pos2(third / 3.0, 0.0),
            egui::pos2((third + 1.0) / 3.0, 1.0),
        );
        ui.add(egui::Image::new((texture, egui::vec2(side, side))).uv(uv));
        let m = self.metrics;
        ui.label(format!(
            "silhouette IoU {:.3} · PSNR {:.2} dB · SSIM {:.3} · L1 {:.4} (over the person's box)",
            m.iou, m.psnr, m.ssim, m.l1
        ));
        if let Some(b) = self.before {
            ui.label(format!(
                "before: IoU {:.3} · PSNR {:.2} dB ({:+.3}, {:+.2} dB)",
                b.iou,
                b.psnr,
                m.iou - b.iou,
                m.psnr - b.psnr
            ));
        }
    }
}
