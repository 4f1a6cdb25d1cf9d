//! The avatar being shown (posed on the GPU by the viewport from the body's current pose), and
//! what its panel shows of the photo it was made from.

use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use glam::Vec2;
use guava::avatar::{Avatar, HandsInView};
use guava::body::{Landmark, Posable, PosedBody};
use guava::fit::{BodyPoint, FitReport};
use guava::keypoints::Keypoint;
use guava::photo::{Crop, SOURCE_SIZE, SourceImage};
use guava::tracking::SourceView;
use guava::view::AvatarRef;

use crate::body_panel::BodyState;
use crate::fidelity::Fidelity;
use crate::ids::next_id;

pub struct AvatarState {
    pub avatar: Arc<Avatar>,
    /// The id the viewport uploads it by (once).
    id: u64,
    /// What it is and where it came from, shown in the panel.
    pub label: String,
    pub source: Option<SourcePreview>,
    /// A GUAVA-mode avatar's photo with its tracked body over it.
    pub tracked_photo: Option<TrackedPhoto>,
    /// The source photo's camera (world→camera, `invtanfov`), when the avatar was made here.
    pub source_camera: Option<(glam::Mat4, f32)>,
    /// Whether the body its photo did not show is drawn (neutral grey).
    pub show_outside: bool,
    /// How it compares with its photo, when it was made here (or why it could not be).
    pub fidelity: Option<Result<Fidelity, String>>,
    /// Its hands the photo did not show, found on the body it is first shown on.
    hands: OnceLock<Option<Arc<HandsInView>>>,
}

impl AvatarState {
    /// The Gaussians drawn: template and UV, without the parts left out unless they are shown.
    pub fn drawn(&self) -> usize {
        let a = &self.avatar;
        a.template.len() + a.skinned.len() + a.shown_uv(self.show_outside)
    }

    pub fn new(
        avatar: Avatar,
        label: String,
        preview: Preview,
        source_camera: Option<(glam::Mat4, f32)>,
        fidelity: Option<Result<Fidelity, String>>,
    ) -> Self {
        let (source, tracked_photo) = match preview {
            Preview::None => (None, None),
            Preview::Fit(p) => (Some(*p), None),
            Preview::Tracked(p) => (None, Some(p)),
        };
        Self {
            avatar: Arc::new(avatar),
            id: next_id(),
            label,
            source,
            tracked_photo,
            source_camera,
            show_outside: false,
            fidelity,
            hands: OnceLock::new(),
        }
    }

    /// The avatar for the viewport, bound to `body`'s mesh.
    pub fn reference(&self, body: &BodyState) -> AvatarRef {
        AvatarRef {
            id: self.id,
            avatar: self.avatar.clone(),
            triangles: body.triangles(),
            weld: body.weld(),
            hands: self.hands(body),
        }
    }

    /// Its hands the photo did not show ([`HandsInView`]), found once.
    pub fn hands(&self, body: &BodyState) -> Option<Arc<HandsInView>> {
        self.hands
            .get_or_init(|| HandsInView::new(&self.avatar, &*body.model).map(Arc::new))
            .clone()
    }
}

/// What the avatar panel shows of the photo an avatar was made from.
pub enum Preview {
    None,
    /// The keypoints and the fit (or the tracked body's landmarks), adjustable by hand.
    Fit(Box<SourcePreview>),
    /// GUAVA mode with a tracking file: the tracked body over the photo.
    Tracked(TrackedPhoto),
}

/// A source photo (the square its camera sees, at the reconstruction's size) as an egui image.
struct Photo {
    image: egui::ColorImage,
    texture: Option<egui::TextureHandle>,
}

impl Photo {
    fn load(photo: &Path, crop: Option<Crop>) -> Option<Self> {
        let source = SourceImage::load_at(photo, crop, SOURCE_SIZE).ok()?;
        let size = source.size as usize;
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        let pixels = source
            .rgb
            .chunks_exact(3)
            .map(|c| egui::Color32::from_rgb(q(c[0]), q(c[1]), q(c[2])))
            .collect();
        Some(Self {
            image: egui::ColorImage::new([size, size], pixels),
            texture: None,
        })
    }

    /// Shows the photo (uploaded once; the image is copied only then); returns where it was drawn
    /// and its pixels' scale on screen.
    fn show(&mut self, ui: &mut egui::Ui) -> (egui::Rect, f32) {
        let texture = self.texture.get_or_insert_with(|| {
            ui.ctx()
                .load_texture("source photo", self.image.clone(), Default::default())
        });
        let side = ui.available_width().min(320.0);
        let response = ui.add(egui::Image::new((texture.id(), egui::vec2(side, side))));
        (response.rect, side / self.image.size[0] as f32)
    }
}

/// The photo a GUAVA-mode avatar was made from with its tracked body's vertices over it, so the
/// user sees whether the tracking lines up with the photo (GUAVA samples the photo there).
pub struct TrackedPhoto {
    photo: Photo,
    /// Every [`TRACKED_POINT_STRIDE`]th vertex projected, in units of the photo's side.
    points: Vec<Vec2>,
}

/// Every how many projected vertices one is drawn (EHM has ~10k).
const TRACKED_POINT_STRIDE: usize = 8;

impl TrackedPhoto {
    /// `body` posed by `view` over the photo; `None` when either cannot be done again.
    pub fn new(photo: &Path, view: &SourceView, body: &impl Posable) -> Option<Self> {
        let mut posed = PosedBody::default();
        body.pose(&view.pose, &mut posed).ok()?;
        let camera = &view.camera;
        let side = camera.width as f32;
        let points = posed
            .vertices
            .iter()
            .step_by(TRACKED_POINT_STRIDE)
            .map(|&v| camera.project(v))
            .filter(|p| p.z > 0.0 && p.is_finite())
            .map(|p| Vec2::new(p.x, p.y) / side)
            .collect();
        Some(Self {
            photo: Photo::load(photo, view.crop)?,
            points,
        })
    }

    pub fn ui(&mut self, ui: &mut egui::Ui) {
        let (rect, _) = self.photo.show(ui);
        let painter = ui.painter_at(rect);
        let colour = egui::Color32::from_rgba_unmultiplied(240, 60, 60, 160);
        for p in &self.points {
            painter.circle_filled(rect.min + egui::vec2(p.x, p.y) * rect.width(), 1.0, colour);
        }
        ui.label(format!(
            "red: the tracked body (every {TRACKED_POINT_STRIDE}th vertex) where the tracking puts \
             it; GUAVA samples the photo there"
        ));
    }
}

/// The source photo with the keypoint models' points and where the fitted (or tracked) body puts
/// the same landmarks, so the user can judge the fit, adjust it by hand with the body sliders and
/// reconstruct the photo again with the adjusted pose.
pub struct SourcePreview {
    photo_image: Photo,
    /// The photo and the pose and camera its avatar was made with.
    pub photo: PathBuf,
    pub view: SourceView,
    /// Per body keypoint: where the model saw it, its confidence, its place on the body.
    keypoints: Vec<(Vec2, f32, BodyPoint)>,
    /// Face-mesh and hand points the fit used: where the models saw them, their place on the body.
    detail: Vec<(Vec2, BodyPoint)>,
    /// Where the shown pose puts the keypoints' landmarks, then the detail points (pixels).
    fitted: Vec<Vec2>,
    /// While editing: the id of the body pose `fitted` was computed for.
    fitted_for: Option<u64>,
    pub rms_px: Option<f32>,
    editing: bool,
}

/// What the user asked of the fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitAction {
    /// The body sliders now pose the photo's body, starting from the fit.
    StartEditing,
    StopEditing,
    /// Reconstruct the photo with the body's current pose and the photo's camera.
    Reconstruct,
    /// Write the current pose and the photo's camera as a tracking file.
    SaveTracking,
}

impl SourcePreview {
    /// The photo with the pose model's `keypoints` (matched by name to `landmarks`, the body's
    /// keypoint landmarks) and the `fit`'s other points, on `body` posed by `view`. `None` when
    /// the pose model did not run (a photo with alpha and tracking) or the photo cannot be read.
    pub fn new(
        body: &impl Posable,
        landmarks: &[Landmark],
        photo: &Path,
        keypoints: &[Keypoint],
        fit: Option<&FitReport>,
        view: SourceView,
    ) -> Option<Self> {
        if keypoints.is_empty() {
            return None;
        }
        let keypoints = keypoints
            .iter()
            .filter_map(|k| {
                let l = landmarks.iter().find(|l| l.name == k.name)?;
                Some((k.pixel, k.confidence, BodyPoint::Surface(l.clone())))
            })
            .collect();
        let face = fit.and_then(|f| f.face.as_ref()).into_iter().flat_map(|f| {
            let surface = f.surface.iter().cloned().map(BodyPoint::Surface);
            f.observed.iter().copied().zip(surface)
        });
        let hands = fit
            .and_then(|f| f.hands.as_ref())
            .into_iter()
            .flat_map(|h| h.observed.iter().copied().zip(h.targets.iter().cloned()));
        let irises = fit.and_then(|f| f.gaze.as_ref()).into_iter().flat_map(|g| {
            let pupils = g.pupils.iter().cloned().map(BodyPoint::Surface);
            g.observed.iter().copied().zip(pupils)
        });
        let detail = face.chain(hands).chain(irises).collect();
        let mut preview = Self {
            photo_image: Photo::load(photo, view.crop)?,
            photo: photo.to_path_buf(),
            view,
            keypoints,
            detail,
            fitted: Vec::new(),
            fitted_for: None,
            rms_px: fit.map(|f| f.rms_px),
            editing: false,
        };
        let mut posed = PosedBody::default();
        body.pose(&preview.view.pose, &mut posed).ok()?;
        preview.fitted = preview.project_all(&posed);
        Some(preview)
    }

    pub fn editing(&self) -> bool {
        self.editing
    }

    fn project_all(&self, posed: &PosedBody) -> Vec<Vec2> {
        let camera = &self.view.camera;
        let landmarks = self.keypoints.iter().map(|k| &k.2);
        let detail = self.detail.iter().map(|d| &d.1);
        landmarks
            .chain(detail)
            .map(|p| {
                let q = camera.project(p.on(posed));
                Vec2::new(q.x, q.y)
            })
            .collect()
    }

    /// The photo with the points and the fit's controls; while editing, the red points follow
    /// `body`'s pose.
    pub fn ui(&mut self, ui: &mut egui::Ui, body: &mut BodyState) -> Option<FitAction> {
        if self.editing {
            let pose = body.posed();
            if self.fitted_for != Some(pose.id) {
                self.fitted = self.project_all(&pose.posed);
                self.fitted_for = Some(pose.id);
            }
        }
        let (rect, scale) = self.photo_image.show(ui);
        let to_screen = |p: Vec2| rect.min + egui::vec2(p.x, p.y) * scale;
        let painter = ui.painter_at(rect);
        let (green, red) = (
            egui::Color32::from_rgb(80, 230, 80),
            egui::Color32::from_rgb(240, 60, 60),
        );
        for (&(seen, confidence, _), &fitted) in self.keypoints.iter().zip(&self.fitted) {
            let (a, b) = (to_screen(seen), to_screen(fitted));
            let used = confidence >= guava::fit::MIN_CONFIDENCE;
            let colour = if used {
                green
            } else {
                egui::Color32::from_gray(150)
            };
            painter.line_segment([a, b], egui::Stroke::new(1.0, egui::Color32::YELLOW));
            painter.circle_stroke(a, 3.5, egui::Stroke::new(1.5, colour));
            painter.circle_filled(b, 2.5, red);
        }
        let detail_fitted = &self.fitted[self.keypoints.len().min(self.fitted.len())..];
        for (&(seen, _), &fitted) in self.detail.iter().zip(detail_fitted) {
            painter.circle_filled(to_screen(seen), 1.2, green);
            painter.circle_filled(to_screen(fitted), 1.2, red);
        }
        ui.label(match (self.editing, self.rms_px) {
            (true, _) => "editing the fit: the Body sliders pose the photo's body; red follows".into(),
            (false, Some(rms)) => format!(
                "green: keypoints used (grey: not confident); red: the fitted body's landmarks; fit {rms:.1} px RMS"
            ),
            (false, None) => "green: keypoints found; red: the tracked body's landmarks".into(),
        });
        let mut action = None;
        ui.horizontal(|ui| {
            if !self.editing {
                if ui
                    .button("Adjust the fit…")
                    .on_hover_text(
                        "pose the photo's body with the Body sliders, starting from the fit",
                    )
                    .clicked()
                {
                    action = Some(FitAction::StartEditing);
                }
                return;
            }
            if ui
                .button("Reconstruct with this pose")
                .on_hover_text("reconstruct the photo again with the body's current pose")
                .clicked()
            {
                action = Some(FitAction::Reconstruct);
            }
            if ui.button("Save as tracking…").clicked() {
                action = Some(FitAction::SaveTracking);
            }
            if ui.button("Stop").clicked() {
                action = Some(FitAction::StopEditing);
            }
        });
        action
    }

    /// Starts or stops editing; starting puts the fit's pose on `body`.
    pub fn set_editing(&mut self, editing: bool, body: &mut BodyState) {
        if editing && !self.editing {
            body.pose = self.view.pose.clone();
        }
        if !editing {
            // Back to the pose the avatar was made with.
            let mut posed = PosedBody::default();
            if body.model.pose(&self.view.pose, &mut posed).is_ok() {
                self.fitted = self.project_all(&posed);
            }
        }
        self.editing = editing;
        self.fitted_for = None;
    }
}
