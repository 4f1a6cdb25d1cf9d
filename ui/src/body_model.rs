//! The body the viewer poses: a body template (the embedded default, or another `.glb`) or GUAVA's
//! EHM (GUAVA mode, from the user's converted SMPL-X and FLAME). One posing API ([`Posable`]) for
//! both, so the sliders, the motion and the avatar treat them alike.

use std::sync::Arc;

use guava::body::{BodyModel, BodyPose, EhmModel, Posable, PoseError, PosedBody, TargetGroup};

#[derive(Clone)]
pub enum ViewerBody {
    // Behind pointers: the two differ several-fold in size; a template is shared with the
    // reconstruction workers.
    Template(Arc<BodyModel>),
    Ehm(Box<EhmModel>),
}

/// A row of sliders: the coefficient's index, its name and range.
pub struct Slider {
    pub index: usize,
    pub name: String,
    pub range: [f32; 2],
}

/// Sliders under one heading.
pub struct SliderGroup {
    pub title: &'static str,
    pub sliders: Vec<Slider>,
    pub open: bool,
}

/// EHM's PCA coefficients are in standard deviations; ±3 covers the tracked range.
const EHM_COEFFICIENT_RANGE: [f32; 2] = [-3.0, 3.0];

impl ViewerBody {
    /// The body template, where the feature needs one (default reconstruction, the fit).
    pub fn template(&self) -> Option<&BodyModel> {
        match self {
            Self::Template(m) => Some(m),
            Self::Ehm(_) => None,
        }
    }

    pub fn ehm_mut(&mut self) -> Option<&mut EhmModel> {
        match self {
            Self::Template(_) => None,
            Self::Ehm(m) => Some(m),
        }
    }

    pub fn is_ehm(&self) -> bool {
        matches!(self, Self::Ehm(_))
    }

    /// "N vertices, M joints" for the panel.
    pub fn size_label(&self) -> String {
        format!(
            "{} vertices, {} joints",
            self.vertex_count(),
            self.joint_names().len()
        )
    }

    /// The coefficient sliders, grouped as the body's parameters are.
    pub fn slider_groups(&self) -> Vec<SliderGroup> {
        match self {
            Self::Template(m) => [
                ("Expression (ARKit face units)", TargetGroup::Expression),
                ("Shape (phenotype ends)", TargetGroup::Shape),
            ]
            .into_iter()
            .map(|(title, group)| SliderGroup {
                title,
                sliders: m
                    .targets_in(group)
                    .map(|(index, t)| Slider {
                        index,
                        name: t.name.clone(),
                        range: t.range,
                    })
                    .collect(),
                open: group == TargetGroup::Expression,
            })
            .collect(),
            Self::Ehm(m) => {
                let groups = [
                    ("FLAME expression", "flame_expression_", true),
                    ("Eyelids", "eyelid_", true),
                    ("SMPL-X expression", "expression_", false),
                    ("SMPL-X shape", "shape_", false),
                    ("FLAME shape", "flame_shape_", false),
                ];
                groups
                    .into_iter()
                    .map(|(title, prefix, open)| SliderGroup {
                        title,
                        sliders: m
                            .parameter_names()
                            .enumerate()
                            .filter(|(_, n)| n.starts_with(prefix))
                            .map(|(index, name)| Slider {
                                index,
                                name: name.to_owned(),
                                range: if prefix == "eyelid_" {
                                    [0.0, 1.0]
                                } else {
                                    EHM_COEFFICIENT_RANGE
                                },
                            })
                            .collect(),
                        open,
                    })
                    .collect()
            }
        }
    }
}

/// Either model's name iterator, as one type.
pub enum Names<A, B> {
    Template(A),
    Ehm(B),
}

impl<'a, A, B> Iterator for Names<A, B>
where
    A: Iterator<Item = &'a str>,
    B: Iterator<Item = &'a str>,
{
    type Item = &'a str;

    fn next(&mut self) -> Option<&'a str> {
        match self {
            Self::Template(a) => a.next(),
            Self::Ehm(b) => b.next(),
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        match self {
            Self::Template(a) => a.size_hint(),
            Self::Ehm(b) => b.size_hint(),
        }
    }
}

impl<'a, A, B> ExactSizeIterator for Names<A, B>
where
    A: ExactSizeIterator<Item = &'a str>,
    B: ExactSizeIterator<Item = &'a str>,
{
}

impl Posable for ViewerBody {
    fn joint_names(&self) -> impl ExactSizeIterator<Item = &str> {
        match self {
            Self::Template(m) => Names::Template(m.joint_names()),
            Self::Ehm(m) => Names::Ehm(m.joint_names()),
        }
    }

    fn parameter_names(&self) -> impl ExactSizeIterator<Item = &str> {
        match self {
            Self::Template(m) => Names::Template(m.parameter_names()),
            Self::Ehm(m) => Names::Ehm(m.parameter_names()),
        }
    }

    fn triangles(&self) -> &[[u32; 3]] {
        match self {
            Self::Template(m) => m.triangles(),
            Self::Ehm(m) => m.triangles(),
        }
    }

    fn name(&self) -> &str {
        match self {
            Self::Template(m) => m.name(),
            Self::Ehm(m) => m.name(),
        }
    }

    fn vertex_count(&self) -> usize {
        match self {
            Self::Template(m) => m.vertex_count(),
            Self::Ehm(m) => m.vertex_count(),
        }
    }

    fn pose(&self, pose: &BodyPose, out: &mut PosedBody) -> Result<(), PoseError> {
        match self {
            Self::Template(m) => m.pose(pose, out),
            Self::Ehm(m) => m.pose(pose, out),
        }
    }

    fn is_identity_parameter(&self, i: usize) -> bool {
        match self {
            Self::Template(m) => m.is_identity_parameter(i),
            Self::Ehm(m) => m.is_identity_parameter(i),
        }
    }

    fn ehm_identity(&self) -> Option<&guava::body::EhmIdentity> {
        match self {
            Self::Template(_) => None,
            Self::Ehm(m) => Some(&m.identity),
        }
    }

    fn weld(&self) -> Option<&[u32]> {
        match self {
            Self::Template(m) => m.weld(),
            Self::Ehm(m) => m.weld(),
        }
    }
}
