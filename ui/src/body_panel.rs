//! The body being posed: its model, the pose the motion (or the advanced editors) set, the
//! grouped controls that override it, and the posed body the viewport draws (as a mesh, or
//! under an avatar). Re-poses only when the resulting pose changed.

use std::sync::Arc;

use glam::Vec3;
use guava::avatar::Avatar;
use guava::body::{BodyPose, Posable, PosedBody, vertex_normals};
use guava::render::mesh::MeshStyle;
use guava::view::{MeshFrame, PoseRef};

use crate::body_model::SliderGroup;
use crate::ids::next_id;
use crate::pose_controls::PoseControls;
use guava::body::AnyBody;

/// Posed positions and normals, shared with the viewport callback without copying.
type PosedMesh = (Arc<Vec<Vec3>>, Arc<Vec<Vec3>>);

pub struct BodyState {
    pub model: Arc<AnyBody>,
    /// Where the model came from, shown in the panel.
    pub label: String,
    /// The pose the motion writes (and the advanced editors edit), before [`Self::controls`].
    pub pose: BodyPose,
    /// Face, hands and body controls in people's terms; touched groups override `pose`.
    pub controls: PoseControls,
    /// CPU time of the last re-pose (skinning), for the HUD.
    pub pose_ms: f32,
    pub shaded: bool,
    pub wireframe: bool,
    selected_joint: usize,
    topology: u64,
    triangles: Arc<Vec<[u32; 3]>>,
    weld: Option<Arc<Vec<u32>>>,
    sliders: Vec<SliderGroup>,
    /// The posed body, shared with the viewport callback without copying, and its pose's id.
    posed: Arc<PosedBody>,
    posed_for: Option<BodyPose>,
    pose_id: u64,
    normals_scratch: Vec<Vec3>,
    /// The mesh view's posed mesh, made when it is first shown after a re-pose.
    mesh: Option<PosedMesh>,
}

impl BodyState {
    pub fn new(model: AnyBody, label: String) -> Self {
        let pose = BodyPose::rest(&model);
        let mut rest = PosedBody::default();
        if let Err(e) = model.pose(&pose, &mut rest) {
            log::error!("posing the rest pose failed: {e}");
        }
        let controls = PoseControls::for_body(&model, &rest);
        let selected_joint = model.joint_names().position(|n| n == "head").unwrap_or(0);
        Self {
            triangles: Arc::new(model.triangles().to_vec()),
            weld: model.weld().map(|w| Arc::new(w.to_vec())),
            sliders: crate::body_model::slider_groups(&model),
            model: Arc::new(model),
            label,
            pose,
            controls,
            pose_ms: 0.0,
            shaded: true,
            wireframe: false,
            selected_joint,
            topology: next_id(),
            posed: Arc::default(),
            posed_for: None,
            pose_id: 0,
            normals_scratch: Vec::new(),
            mesh: None,
        }
    }

    /// Builds the body with `avatar`'s identity: its shape coefficients on the pose and, on an
    /// EHM body, its joint offsets and head and hand scales on the model. The pose starts as the
    /// avatar's photo shows it ([`Avatar::base_pose`]).
    pub fn take_identity(&mut self, avatar: &Avatar) {
        self.pose = avatar.base_pose(&*self.model);
        if self.model.is_ehm()
            && let Some(ehm) = Arc::make_mut(&mut self.model).ehm_mut()
        {
            avatar.apply_ehm_identity(ehm);
            self.posed_for = None;
        }
    }

    /// Bounds of the posed mesh (for framing the camera).
    pub fn bounds(&mut self) -> (Vec3, Vec3) {
        self.update();
        self.posed
            .vertices
            .iter()
            .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), v| {
                (lo.min(*v), hi.max(*v))
            })
    }

    /// The pose shown: [`Self::pose`] with the overridden control groups in place.
    pub fn effective_pose(&self) -> BodyPose {
        let mut pose = self.pose.clone();
        self.controls.apply(&mut pose);
        pose
    }

    fn update(&mut self) {
        // The motion's pose as it is unless a group overrides part of it (no copy per frame).
        let pose = match self.controls.overridden().next() {
            Some(_) => std::borrow::Cow::Owned(self.effective_pose()),
            None => std::borrow::Cow::Borrowed(&self.pose),
        };
        if self.posed_for.as_ref() == Some(&*pose) {
            return;
        }
        // In place unless the viewport still holds the last pose.
        let started = std::time::Instant::now();
        if let Err(e) = self.model.pose(&pose, Arc::make_mut(&mut self.posed)) {
            log::error!("posing failed: {e}");
            return;
        }
        self.pose_ms = started.elapsed().as_secs_f32() * 1e3;
        self.mesh = None;
        self.posed_for = Some(pose.into_owned());
        self.pose_id = next_id();
    }

    /// The posed body and its pose's id (new with every re-pose), re-posed first if the pose
    /// changed.
    pub fn posed(&mut self) -> PoseRef {
        self.update();
        PoseRef {
            id: self.pose_id,
            posed: self.posed.clone(),
        }
    }

    /// The posed mesh for the viewport, re-posed first if a slider moved.
    pub fn frame(&mut self, background: [f32; 3]) -> MeshFrame {
        self.update();
        let (positions, normals) = self
            .mesh
            .get_or_insert_with(|| {
                let mut normals = Vec::new();
                vertex_normals(
                    &self.posed.vertices,
                    &self.triangles,
                    self.weld.as_deref().map(Vec::as_slice),
                    &mut self.normals_scratch,
                    &mut normals,
                );
                (Arc::new(self.posed.vertices.clone()), Arc::new(normals))
            })
            .clone();
        MeshFrame {
            topology: self.topology,
            pose: self.pose_id,
            triangles: self.triangles.clone(),
            positions,
            normals,
            style: MeshStyle {
                shaded: self.shaded,
                wireframe: self.wireframe,
                background,
                overlay: None,
            },
        }
    }

    /// The body's triangles, shared with the viewport.
    pub fn triangles(&self) -> Arc<Vec<[u32; 3]>> {
        self.triangles.clone()
    }

    /// The body's seam weld (`None`: it splits no vertices), shared with the viewport.
    pub fn weld(&self) -> Option<Arc<Vec<u32>>> {
        self.weld.clone()
    }

    /// The panel; returns whether the pose was put to rest (a layered motion then layers on
    /// the rest pose instead of the photo's).
    pub fn ui(&mut self, ui: &mut egui::Ui) -> bool {
        ui.label(&self.label);
        let rest = ui
            .horizontal(|ui| {
                ui.checkbox(&mut self.shaded, "shaded");
                ui.checkbox(&mut self.wireframe, "wireframe");
                ui.button("Rest pose")
                    .on_hover_text("every joint and parameter at rest, every group reset")
                    .clicked()
            })
            .inner;
        if rest {
            self.pose = BodyPose::rest(self.model.as_ref());
            self.controls.groups.iter_mut().for_each(|g| g.reset());
        }
        self.controls.ui(ui);
        egui::CollapsingHeader::new("Any joint or parameter (advanced)")
            .default_open(false)
            .show(ui, |ui| self.rig_ui(ui));
        rest
    }

    /// The rig's own joints and parameters, one slider each.
    fn rig_ui(&mut self, ui: &mut egui::Ui) {
        let model = self.model.clone();
        ui.add(egui::Slider::new(&mut self.pose.translation.y, -2.0..=2.0).text("lift (m)"));
        ui.label("Joint rotation (axis-angle, degrees)");
        let joint_name = |j: usize| model.joint_names().nth(j).unwrap_or_default();
        egui::ComboBox::new("joint", "joint")
            .selected_text(joint_name(self.selected_joint))
            .height(300.0)
            .show_ui(ui, |ui| {
                for (j, name) in model.joint_names().enumerate() {
                    ui.selectable_value(&mut self.selected_joint, j, name);
                }
            });
        let r = &mut self.pose.rotations[self.selected_joint];
        for (axis, value) in ["x", "y", "z"].iter().zip([&mut r.x, &mut r.y, &mut r.z]) {
            let mut deg = value.to_degrees();
            if ui
                .add(egui::Slider::new(&mut deg, -180.0..=180.0).text(*axis))
                .changed()
            {
                *value = deg.to_radians();
            }
        }
        for group in &self.sliders {
            egui::CollapsingHeader::new(group.title)
                .default_open(group.open)
                .show(ui, |ui| {
                    for s in &group.sliders {
                        let [lo, hi] = s.range;
                        ui.add(
                            egui::Slider::new(&mut self.pose.coefficients[s.index], lo..=hi)
                                .text(&s.name),
                        );
                    }
                });
        }
    }
}
