//! Either body an avatar is posed on: a body template (the embedded default, or another
//! `.glb`; the default reconstruction's) or GUAVA's EHM (GUAVA mode). One type for the viewer,
//! the CLI and the tools, posed through one API ([`Posable`]).

use std::sync::Arc;

use super::{BodyModel, BodyPose, EhmIdentity, EhmModel, Posable, PoseError, PosedBody};

#[derive(Clone)]
pub enum AnyBody {
    // Behind pointers: the two differ several-fold in size; a template is shared with the
    // reconstruction workers.
    Template(Arc<BodyModel>),
    Ehm(Box<EhmModel>),
}

/// [`AnyBody`] borrowed: made from it, or from bodies held elsewhere (a reconstruction's mode,
/// a tracker's template). What a photo's view is fitted on.
#[derive(Clone, Copy)]
pub enum BodyRef<'a> {
    Template(&'a BodyModel),
    Ehm(&'a EhmModel),
}

impl AnyBody {
    pub fn borrowed(&self) -> BodyRef<'_> {
        match self {
            Self::Template(m) => BodyRef::Template(m),
            Self::Ehm(m) => BodyRef::Ehm(m),
        }
    }

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

impl Posable for AnyBody {
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

    fn ehm_identity(&self) -> Option<&EhmIdentity> {
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

    fn part_of(&self, v: usize) -> Option<&str> {
        match self {
            Self::Template(m) => m.part_of(v),
            Self::Ehm(m) => Posable::part_of(m.as_ref(), v),
        }
    }

    fn dominant_joint(&self, v: usize) -> Option<usize> {
        match self {
            Self::Template(m) => Posable::dominant_joint(m.as_ref(), v),
            Self::Ehm(m) => Posable::dominant_joint(m.as_ref(), v),
        }
    }
}
