//! The body being posed by hand: its model, the pose the sliders edit, and the posed mesh the
//! viewport draws. Re-poses only when the pose changed.

use std::sync::Arc;

use glam::Vec3;
use guava::body::{BodyModel, BodyPose, PosedBody, TargetGroup, vertex_normals};
use guava::render::mesh::MeshStyle;

use crate::viewport::BodyFrame;

/// Posed positions and normals, shared with the viewport callback without copying.
type PosedMesh = (Arc<Vec<Vec3>>, Arc<Vec<Vec3>>);

pub struct BodyState {
    pub model: Arc<BodyModel>,
    /// Where the model came from, shown in the panel.
    pub label: String,
    pub pose: BodyPose,
    pub shaded: bool,
    pub wireframe: bool,
    selected_joint: usize,
    topology: u64,
    triangles: Arc<Vec<[u32; 3]>>,
    posed: PosedBody,
    posed_for: Option<BodyPose>,
    pose_generation: u64,
    normals_scratch: Vec<Vec3>,
    frame: Option<PosedMesh>,
}

impl BodyState {
    pub fn new(model: BodyModel, label: String, topology: u64) -> Self {
        let pose = BodyPose::rest(&model);
        let selected_joint = model.joint_index("head").unwrap_or(0);
        Self {
            triangles: Arc::new(model.triangles.clone()),
            model: Arc::new(model),
            label,
            pose,
            shaded: true,
            wireframe: false,
            selected_joint,
            topology,
            posed: PosedBody::default(),
            posed_for: None,
            pose_generation: 0,
            normals_scratch: Vec::new(),
            frame: None,
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

    fn update(&mut self) {
        if self.posed_for.as_ref() == Some(&self.pose) {
            return;
        }
        if let Err(e) = self.model.pose(&self.pose, &mut self.posed) {
            log::error!("posing failed: {e}");
            return;
        }
        let mut normals = Vec::new();
        vertex_normals(
            &self.posed.vertices,
            &self.model.triangles,
            &self.model.weld,
            &mut self.normals_scratch,
            &mut normals,
        );
        self.frame = Some((Arc::new(self.posed.vertices.clone()), Arc::new(normals)));
        self.posed_for = Some(self.pose.clone());
        self.pose_generation += 1;
    }

    /// The posed body and its pose generation (which changes with every re-pose), re-posed first
    /// if the pose changed.
    pub fn posed(&mut self) -> (&PosedBody, u64) {
        self.update();
        (&self.posed, self.pose_generation)
    }

    /// The posed mesh for the viewport, re-posed first if a slider moved.
    pub fn frame(&mut self, background: [f32; 3]) -> Option<BodyFrame> {
        self.update();
        let (positions, normals) = self.frame.clone()?;
        Some(BodyFrame {
            topology: self.topology,
            pose: self.pose_generation,
            triangles: self.triangles.clone(),
            positions,
            normals,
            style: MeshStyle {
                shaded: self.shaded,
                wireframe: self.wireframe,
                background,
            },
        })
    }

    pub fn ui(&mut self, ui: &mut egui::Ui) {
        ui.label(&self.label);
        ui.horizontal(|ui| {
            ui.checkbox(&mut self.shaded, "shaded");
            ui.checkbox(&mut self.wireframe, "wireframe");
            if ui.button("Rest pose").clicked() {
                self.pose = BodyPose::rest(self.model.as_ref());
            }
        });
        let model = self.model.clone();
        ui.add(egui::Slider::new(&mut self.pose.translation.y, -2.0..=2.0).text("lift (m)"));
        ui.label("Joint rotation (axis-angle, degrees)");
        egui::ComboBox::new("joint", "joint")
            .selected_text(&model.joints[self.selected_joint].name)
            .height(300.0)
            .show_ui(ui, |ui| {
                for (j, joint) in model.joints.iter().enumerate() {
                    ui.selectable_value(&mut self.selected_joint, j, &joint.name);
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
        for (title, group) in [
            ("Expression (ARKit face units)", TargetGroup::Expression),
            ("Shape (phenotype ends)", TargetGroup::Shape),
        ] {
            egui::CollapsingHeader::new(title)
                .default_open(group == TargetGroup::Expression)
                .show(ui, |ui| {
                    for (i, target) in model.targets_in(group) {
                        let [lo, hi] = target.range;
                        ui.add(
                            egui::Slider::new(&mut self.pose.coefficients[i], lo..=hi)
                                .text(&target.name),
                        );
                    }
                });
        }
    }
}
