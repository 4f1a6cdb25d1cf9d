//! The avatar being shown: its Gaussians rigged onto the current body pose (sliders or motion),
//! re-rigged only when the pose changed, as a scene for the splatting viewport.

use std::sync::Arc;

use glam::Vec2;
use guava::avatar::{Avatar, Rig};
use guava::body::{BodyModel, PosedBody};
use guava::gaussians::GaussianCloud;
use guava::reconstruct::{Report, SourceImage, SourceView};

use crate::body_panel::BodyState;
use crate::viewport::SceneRef;

pub struct AvatarState {
    pub avatar: Arc<Avatar>,
    /// What it is and where it came from, shown in the panel.
    pub label: String,
    pub source: Option<SourcePreview>,
    /// The source photo's camera (world→camera, `invtanfov`), when the avatar was made here.
    pub source_camera: Option<(glam::Mat4, f32)>,
    rig: Rig,
    rigged_for: Option<u64>,
    scene: Option<SceneRef>,
}

impl AvatarState {
    pub fn new(
        avatar: Avatar,
        label: String,
        source: Option<SourcePreview>,
        source_camera: Option<(glam::Mat4, f32)>,
    ) -> Self {
        Self {
            avatar: Arc::new(avatar),
            label,
            source,
            source_camera,
            rig: Rig::default(),
            rigged_for: None,
            scene: None,
        }
    }

    /// The avatar on `body`'s current pose; a new scene generation (taken from `generation`)
    /// only when the pose changed.
    pub fn scene(&mut self, body: &mut BodyState, generation: &mut u64) -> Option<SceneRef> {
        let model = body.model.clone();
        let (posed, pose_generation) = body.posed();
        if self.rigged_for != Some(pose_generation) || self.scene.is_none() {
            let mut cloud = self
                .scene
                .take()
                .and_then(|s| Arc::try_unwrap(s.cloud).ok())
                .unwrap_or_else(|| GaussianCloud::new(self.avatar.channels));
            if let Err(e) = self
                .rig
                .animate(&self.avatar, posed, &model.triangles, &mut cloud)
            {
                log::error!("{e}");
                return None;
            }
            *generation += 1;
            self.scene = Some(SceneRef {
                generation: *generation,
                cloud: Arc::new(cloud),
            });
            self.rigged_for = Some(pose_generation);
        }
        self.scene.clone()
    }
}

/// The source photo with the pose model's keypoints and where the fitted (or tracked) body puts
/// the same landmarks, so the user can judge the fit.
pub struct SourcePreview {
    image: egui::ColorImage,
    texture: Option<egui::TextureHandle>,
    /// Per keypoint: where the model saw it (pixels of the square crop), its confidence, and the
    /// source body's landmark projected by the source camera.
    points: Vec<(Vec2, f32, Vec2)>,
    pub rms_px: Option<f32>,
}

impl SourcePreview {
    /// `None` when the pose model did not run (a photo with alpha and tracking).
    pub fn new(
        body: &BodyModel,
        photo: &std::path::Path,
        report: &Report,
        view: &SourceView,
    ) -> Option<Self> {
        if report.keypoints.is_empty() {
            return None;
        }
        let source = SourceImage::load(photo).ok()?;
        let size = source.size as usize;
        let pixels = source
            .rgb
            .chunks_exact(3)
            .map(|c| {
                let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
                egui::Color32::from_rgb(q(c[0]), q(c[1]), q(c[2]))
            })
            .collect();
        let mut posed = PosedBody::default();
        body.pose(&view.pose, &mut posed).ok()?;
        let landmarks = body.landmark_positions(&posed.vertices);
        let points = report
            .keypoints
            .iter()
            .filter_map(|k| {
                let l = body.landmarks.iter().position(|l| l.name == k.name)?;
                let q = view.camera.project(landmarks[l]);
                Some((k.pixel, k.confidence, Vec2::new(q.x, q.y)))
            })
            .collect();
        Some(Self {
            image: egui::ColorImage::new([size, size], pixels),
            texture: None,
            points,
            rms_px: report.fit.as_ref().map(|f| f.rms_px),
        })
    }

    pub fn ui(&mut self, ui: &mut egui::Ui) {
        // Uploaded once; the image is copied only then.
        let texture = self.texture.get_or_insert_with(|| {
            ui.ctx()
                .load_texture("source photo", self.image.clone(), Default::default())
        });
        let side = ui.available_width().min(320.0);
        let response = ui.add(egui::Image::new((texture.id(), egui::vec2(side, side))));
        let rect = response.rect;
        let scale = side / self.image.size[0] as f32;
        let to_screen = |p: Vec2| rect.min + egui::vec2(p.x, p.y) * scale;
        let painter = ui.painter_at(rect);
        for &(seen, confidence, fitted) in &self.points {
            let (a, b) = (to_screen(seen), to_screen(fitted));
            let used = confidence >= guava::fit::MIN_CONFIDENCE;
            let colour = if used {
                egui::Color32::from_rgb(80, 230, 80)
            } else {
                egui::Color32::from_gray(150)
            };
            painter.line_segment([a, b], egui::Stroke::new(1.0, egui::Color32::YELLOW));
            painter.circle_stroke(a, 3.5, egui::Stroke::new(1.5, colour));
            painter.circle_filled(b, 2.5, egui::Color32::from_rgb(240, 60, 60));
        }
        ui.label(match self.rms_px {
            Some(rms) => format!(
                "green: keypoints used (grey: not confident); red: the fitted body's landmarks; fit {rms:.1} px RMS"
            ),
            None => "green: keypoints found; red: the tracked body's landmarks".into(),
        });
    }
}
