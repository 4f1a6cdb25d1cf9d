//! An animatable Gaussian avatar: GUAVA's two Gaussian sets bound to a body model (paper Sec. 3).
//!
//! - *Template Gaussians*, one per body vertex: they sit on the posed vertex and turn with its
//!   skinning transform.
//! - *UV Gaussians*, one per kept UV texel: bound to a triangle by barycentrics, with an offset,
//!   rotation and scale in that triangle's frame, so they ride the posed surface.
//!
//! Reconstruction makes one; [`Rig`] turns it into a
//! [`GaussianCloud`](crate::gaussians::GaussianCloud) for any pose of its body on the CPU (the
//! frame path poses it on the GPU: `render::GpuAvatar`); the `.guava` file saves and loads it
//! bit-identically.

mod animate;
mod dress;
pub mod file;
mod hands_in_view;
mod preview;

pub use animate::{BodyMismatch, Rig, blend, quat_from_matrix, quat_mul};
pub use dress::Dressing;
pub use file::{AVATAR_FORMAT, AvatarFileError};
pub use hands_in_view::{HandsInView, SEEN_MARGIN, seen_within};

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::body::{BodyPose, EhmModel, Posable};
use crate::tracking::{EhmIdentityRecord, SourceView};

/// Which pipeline made an avatar; shown to the user, never conflated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AvatarKind {
    /// Our default reconstruction (no learned weights): photo colours on surface discs.
    DefaultReconstruction,
    /// GUAVA's learned decoders (GUAVA mode).
    Guava,
}

impl AvatarKind {
    /// How its Gaussians are low-passed when splatted: as GUAVA's rasterizer, which its decoders
    /// were trained through, or compensated for the default reconstruction's discs.
    pub fn low_pass(self) -> crate::gaussians::LowPass {
        match self {
            Self::DefaultReconstruction => crate::gaussians::LowPass::Compensated,
            Self::Guava => crate::gaussians::LowPass::Dilated,
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            Self::DefaultReconstruction => "default reconstruction (not the learned GUAVA model)",
            Self::Guava => "GUAVA reconstruction",
        }
    }
}

/// Per-Gaussian attributes in the local frame they are bound to; activated values (linear
/// scale, opacity in [0, 1]); quaternions (w, x, y, z).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LocalGaussians {
    pub rotations: Vec<[f32; 4]>,
    pub scales: Vec<[f32; 3]>,
    pub opacities: Vec<f32>,
    /// `channels` values per Gaussian; the first three are RGB in [0, 1].
    pub features: Vec<f32>,
}

impl LocalGaussians {
    pub fn len(&self) -> usize {
        self.opacities.len()
    }

    pub fn is_empty(&self) -> bool {
        self.opacities.is_empty()
    }
}

/// UV Gaussians: where each is bound, and its attributes in the triangle's frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UvGaussians {
    pub triangles: Vec<u32>,
    pub barycentrics: Vec<[f32; 3]>,
    /// Offset from the barycentric point, in units of the triangle's scale σ, in its frame.
    pub offsets: Vec<[f32; 3]>,
    /// Scales are in units of σ; rotations are relative to the triangle frame.
    pub local: LocalGaussians,
}

impl UvGaussians {
    /// Appends `other`'s Gaussians (same channel count).
    pub fn append(&mut self, mut other: UvGaussians) {
        self.triangles.append(&mut other.triangles);
        self.barycentrics.append(&mut other.barycentrics);
        self.offsets.append(&mut other.offsets);
        let (a, b) = (&mut self.local, &mut other.local);
        a.rotations.append(&mut b.rotations);
        a.scales.append(&mut b.scales);
        a.opacities.append(&mut b.opacities);
        a.features.append(&mut b.features);
    }
}

/// Gaussians skinned by a blend of body vertices: what lies beyond the body (hair, loose
/// clothing, a held object). Each follows the weighted mean of up to four posed vertices,
/// turned by their blended skinning, so it moves as the body surface around it does (clothed-
/// avatar methods diffuse skinning weights from the body this way) rather than rigidly with one
/// triangle: μ = Σ w_k v_k + S·Δμ, r = q(S) ⊗ r, S = Σ w_k S_k the blended skinning's linear
/// part (taken as given, as for the template Gaussians).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkinnedGaussians {
    /// Up to four body vertices each; unused slots have weight 0.
    pub vertices: Vec<[u32; 4]>,
    /// Summing to 1.
    pub weights: Vec<[f32; 4]>,
    /// From the vertices' weighted mean, in the blended skinning's rest frame (metres).
    pub offsets: Vec<[f32; 3]>,
    /// Rotations relative to the blended skinning's; scales in metres.
    pub local: LocalGaussians,
}

impl SkinnedGaussians {
    pub fn len(&self) -> usize {
        self.local.len()
    }

    pub fn is_empty(&self) -> bool {
        self.local.is_empty()
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Avatar {
    pub kind: AvatarKind,
    /// The body model the Gaussians are bound to, by name and size (checked when animating).
    pub body: String,
    pub body_vertices: usize,
    pub body_triangles: usize,
    pub channels: usize,
    /// The source's identity coefficients (shape) by parameter name; every pose uses them.
    pub identity: BTreeMap<String, f32>,
    /// EHM's per-avatar skeleton (joint offsets, head and hand scale) the source was tracked
    /// with: GUAVA-mode avatars carry it, and their body is posed with it.
    pub ehm_identity: Option<EhmIdentityRecord>,
    /// Where it came from (the photo's file name), shown to the user.
    pub source: String,
    /// The view the photo was seen from (the body's pose, the camera, the photo's square), for
    /// re-rendering the avatar as the photo shows it; `None` in files older than version 2.
    pub source_view: Option<SourceView>,
    /// Per body vertex, how far the surface the avatar wears (clothing) stands off the body
    /// along its posed normal, in metres; empty when it wears none. Applied to the posed body
    /// before the Gaussians are rigged ([`Dressing`]).
    pub displacements: Vec<f32>,
    /// One per body vertex, in vertex order; rotations relative to the vertex's skinning rotation.
    pub template: LocalGaussians,
    pub uv: UvGaussians,
    /// What lies beyond the body ([`SkinnedGaussians`]); drawn after the template Gaussians and
    /// before the UV Gaussians.
    pub skinned: SkinnedGaussians,
    /// How many of the last UV Gaussians lie on body parts the photo did not show (below an
    /// upper-body portrait's edge): neutral grey, and drawn only when asked
    /// ([`Avatar::shown_uv`]), so the avatar is an upper-body avatar as GUAVA's is. Hands are
    /// not among them (since 2026-12-07): they are drawn where the photo looked ([`HandsInView`]).
    pub outside: usize,
}

impl Avatar {
    /// Whether `body` is the model this avatar is bound to (name, size, identity parameters).
    pub fn check_body(&self, body: &impl Posable) -> Result<(), String> {
        let (name, vertices) = (body.name(), body.vertex_count());
        let triangles = body.triangles().len();
        if name != self.body || vertices != self.body_vertices || triangles != self.body_triangles {
            return Err(format!(
                "the avatar is bound to body {:?} ({} vertices, {} triangles), not {:?} ({} vertices, {} triangles)",
                self.body, self.body_vertices, self.body_triangles, name, vertices, triangles
            ));
        }
        if self.ehm_identity.is_some() && body.ehm_identity().is_none() {
            return Err(format!(
                "the avatar carries EHM's joint offsets and head and hand scales, which body {name:?} does not take"
            ));
        }
        match self
            .identity
            .keys()
            .find(|n| !body.parameter_names().any(|p| p == n.as_str()))
        {
            Some(name) => Err(format!(
                "identity parameter {name:?} is not one of the body's"
            )),
            None => Ok(()),
        }
    }

    /// Sets the avatar's identity coefficients on `pose` (a pose of the body it is bound to).
    pub fn apply_identity(&self, body: &impl Posable, pose: &mut BodyPose) {
        for (i, name) in body.parameter_names().enumerate() {
            if let Some(&value) = self.identity.get(name) {
                pose.coefficients[i] = value;
            }
        }
    }

    /// The pose a motion starts from: the avatar's photo's (when it keeps its source view), so
    /// that joints the motion does not drive stay as the photo shows them (an arm it hid,
    /// resting along the body) rather than in the template's rest pose, which no person stands
    /// in (the default body's arms out at 45°: the demo avatar's suit swung out with them like
    /// wings); the identity applied.
    pub fn base_pose(&self, body: &impl Posable) -> BodyPose {
        let rest = BodyPose::rest(body);
        let mut pose = match &self.source_view {
            Some(view)
                if view.pose.rotations.len() == rest.rotations.len()
                    && view.pose.coefficients.len() == rest.coefficients.len() =>
            {
                view.pose.clone()
            }
            _ => rest,
        };
        self.apply_identity(body, &mut pose);
        pose
    }

    /// Builds `body` with the avatar's EHM identity (the neutral one when it carries none), as
    /// every pose of the avatar needs.
    pub fn apply_ehm_identity(&self, body: &mut EhmModel) {
        body.identity = self
            .ehm_identity
            .as_ref()
            .map_or_else(Default::default, EhmIdentityRecord::to_identity);
    }

    pub fn len(&self) -> usize {
        self.template.len() + self.skinned.len() + self.uv.local.len()
    }

    /// Its Gaussians by set, as every report writes them: "15066 template + 39003 beyond the
    /// body + 125883 UV".
    pub fn composition(&self) -> String {
        format!(
            "{} template + {} beyond the body + {} UV",
            self.template.len(),
            self.skinned.len(),
            self.uv.local.len()
        )
    }

    /// The UV Gaussians drawn: all of them with `outside`, else those on what the photo showed.
    pub fn shown_uv(&self, outside: bool) -> usize {
        if outside {
            self.uv.local.len()
        } else {
            self.uv.local.len() - self.outside
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}
