//! Reconstruction from one photo (paper Sec. 3), the shared core of both modes: the source view
//! (pose and camera), the masked photo and the body model in; an animatable [`Avatar`] out.
//! [`crate::pipeline`] reads the photo and finds its view first.
//!
//! Stages, each timed: pose the body in the source pose → rasterize it from the source camera
//! (z-buffer, and the person mask when the photo has none) → inverse texture mapping of the
//! photo into the body's UV map with per-texel visibility → fill what the camera did not see
//! (default mode) → Gaussians bound to the surface.
//!
//! This module holds the **default reconstruction** (no GUAVA weights); the learned decoders
//! plug in after the same inverse texture mapping in [`crate::guava_mode`].

pub mod behind;
pub mod default_mode;
pub mod displacement;
pub mod extras;
pub mod eyes;
pub mod fill;
pub mod hair;
mod hanging;
pub mod past_edge;
pub mod texture;
pub mod unseen_parts;
pub mod uv_map;

use std::collections::BTreeMap;
use std::time::Duration;

use crate::avatar::{Avatar, SEEN_MARGIN, seen_within};
use crate::body::{BodyModel, BodyPose, PoseError, PosedBody, TargetGroup};
use crate::photo::{PhotoError, Shown, SourceImage};
use crate::progress::{Cancelled, Stage, StageClock};
use crate::raster;
use crate::tracking::{SourceView, TrackingError};
pub use default_mode::{DEFAULT_CHANNELS, DiscStyle};
pub use uv_map::UvMap;

/// The default reconstruction's UV map side: at 448² the Anny body has ~126k valid texels, which
/// with its 15,066 template Gaussians stays under GUAVA's ~150k total.
pub const DEFAULT_UV_SIZE: u32 = 448;

#[derive(Debug, thiserror::Error)]
pub enum ReconstructError {
    #[error(transparent)]
    Photo(#[from] PhotoError),
    #[error(
        "the tracked camera sees none of the body's surface in the photo (is the tracking file the \
         photo's, and does the photo show the person?)"
    )]
    NothingVisible,
    #[error(transparent)]
    TrackingFile(#[from] TrackingError),
    #[error(transparent)]
    Pose(#[from] PoseError),
    #[error("keypoint models: {0}")]
    Keypoints(String),
    #[error("{0}")]
    Models(String),
    #[error("GUAVA models: {0}")]
    Network(#[from] crate::onnx::OnnxError),
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// What a reconstruction reports besides the avatar: its stages' times and what it saw.
#[derive(Clone, Debug, Default)]
pub struct Report {
    pub timings: Vec<(Stage, Duration)>,
    /// Valid texels of the UV map.
    pub texels: usize,
    /// Texels the source camera saw.
    pub observed: usize,
    /// Default mode: texels filled from their mirror image.
    pub mirrored: usize,
    /// Texels of the back coloured from the front in front of them.
    pub behind: usize,
    /// Texels of hands, teeth and eyes the photo does not show, coloured as what it shows of
    /// them or from the face's skin.
    pub unseen_parts: usize,
    /// Texels of the body below the photo's bottom edge, coloured as the edge shows the person there.
    pub past_edge: usize,
    /// GUAVA mode: UV Gaussians dropped at opacity ≤ 0.001.
    pub pruned: usize,
    /// GUAVA mode: triangles that win at least one pixel of the source view.
    pub visible_faces: usize,
    /// Default mode: Gaussians made for person pixels the body does not cover.
    pub extras: usize,
    /// Default mode: UV Gaussians on parts the photo did not show (greyed, drawn on request).
    pub left_out: usize,
    /// Default mode: how far hair stands off the head (metres) as the photo's outline shows it,
    /// and the Gaussians of the hair's shell behind the head (among [`Report::extras`]).
    pub hair: f32,
    pub hair_shell: usize,
    /// Default mode: the clothing layer's fit, when the photo had a person mask.
    pub dressed: Option<displacement::DisplacementReport>,
}

/// The identity coefficients of `pose` (the shape targets it sets), stored with the avatar.
fn identity_of(body: &BodyModel, pose: &BodyPose) -> BTreeMap<String, f32> {
    body.targets_in(TargetGroup::Shape)
        .filter(|(i, _)| pose.coefficients[*i] != 0.0)
        .map(|(i, t)| (t.name.clone(), pose.coefficients[i]))
        .collect()
}

/// Default reconstruction of `photo` seen from `view`. `uv` is the body's UV map (built once per
/// body, [`UvMap::for_body`]). `progress` hears each stage as it starts and returns `false` to
/// cancel. `source_name` is stored with the avatar.
pub fn reconstruct_default(
    body: &BodyModel,
    uv: &UvMap,
    view: &SourceView,
    mut photo: SourceImage,
    source_name: &str,
    progress: &mut dyn FnMut(Stage) -> bool,
) -> Result<(Avatar, Report), ReconstructError> {
    let mut report = Report {
        texels: uv.len(),
        ..Default::default()
    };
    let mut clock = StageClock::default();
    let camera = &view.camera;

    clock.start(Stage::Pose, progress)?;
    let mut posed = PosedBody::default();
    body.pose(&view.pose, &mut posed)?;

    // The clothing layer, fitted to the person's silhouette where the photo has a mask; the
    // Gaussians then ride the dressed surface, as they will when animated.
    clock.start(Stage::Dress, progress)?;
    let mut displacements = Vec::new();
    if let Some(mask) = &photo.mask {
        let (offsets, dressed) =
            displacement::fit_displacements(body, &posed, camera, mask, photo.shown);
        let vertices = crate::avatar::Dressing::default()
            .apply(&offsets, &posed.vertices, &body.triangles, Some(&body.weld))
            .to_vec();
        posed.vertices = vertices;
        report.dressed = Some(dressed);
        displacements = offsets;
    }

    clock.start(Stage::Rasterize, progress)?;
    let fragments = raster::rasterize(&posed.vertices, &body.triangles, camera);
    if photo.mask.is_none() {
        photo.apply_mask(fragments.coverage());
    }

    clock.start(Stage::TextureMap, progress)?;
    let sampler = texture::Sampler::new(body, &posed.vertices, camera, &photo, &fragments);
    let sampled = sampler.texture(uv);
    report.observed = sampled.observed();

    clock.start(Stage::Fill, progress)?;
    use fill::FillSource;
    let crown = behind::crown(body, uv, &sampled);
    let past = past_edge::past_edge(
        body,
        uv,
        &posed.vertices,
        camera,
        &photo,
        &fragments,
        &sampled,
    );
    let unseen = unseen_parts::unseen_parts(body, uv, &sampled);
    let guesses: Vec<_> = behind::behind(body, uv, &sampled, crown)
        .into_iter()
        .zip(unseen.texels)
        .zip(past)
        .map(|((back, part), past)| {
            // An unseen hand is a hand on its back too, not the sleeve in front of it; below the
            // photo's bottom edge the back goes on with what the edge shows, as the front does.
            (part.map(|c| (FillSource::UnseenPart, c)))
                .or(past.map(|c| (FillSource::PastEdge, c)))
                .or(back.map(|c| (FillSource::Behind, c)))
        })
        .collect();
    let filled = fill::fill(uv, &sampled, &guesses).ok_or(ReconstructError::NothingVisible)?;
    let count = |of: FillSource| filled.source.iter().filter(|&&s| s == of).count();
    report.mirrored = count(FillSource::Mirrored);
    report.behind = count(FillSource::Behind);
    report.unseen_parts = count(FillSource::UnseenPart);
    report.past_edge = count(FillSource::PastEdge);

    clock.start(Stage::Gaussians, progress)?;
    let mut avatar = default_mode::build(
        body,
        &posed,
        uv,
        &filled,
        &DiscStyle::default(),
        identity_of(body, &view.pose),
        source_name.into(),
    );
    // The eyeballs finer than the UV map has them: as the photo shows them, else as guessed.
    avatar.uv.append(eyes::fine_eyes(
        body,
        &posed.vertices,
        &sampler,
        &unseen.eyes,
        &DiscStyle::default(),
    ));
    avatar.source_view = Some(view.clone());
    avatar.displacements = displacements;

    clock.start(Stage::Extras, progress)?;
    if let Some(mask) = &photo.mask {
        report.hair = hair::thickness(body, &posed, camera, mask, photo.shown);
    }
    avatar.skinned = extras::extras(
        &past_edge::continued_below(&photo),
        &fragments,
        body,
        &posed.vertices,
        &posed,
        camera,
        report.hair,
    );
    // Hair's volume behind the head, in the crown's colour (the back of the head's).
    if let (Some(_), Some(crown)) = (&photo.mask, crown) {
        report.hair_shell = hair::shell(
            &mut avatar.skinned,
            body,
            &posed,
            camera,
            &fragments,
            report.hair,
            crown,
        );
    }
    report.extras = avatar.skinned.len();
    report.left_out = leave_out(&mut avatar, body, &posed.vertices, camera, photo.shown);
    report.timings = clock.finish();
    Ok((avatar, report))
}

/// The joints whose vertices are a leg's (their names' beginnings): kept only inside the photo.
pub const LEG_JOINTS: [&str; 3] = ["upperleg", "lowerleg", "foot"];

/// The grey that parts of the body the photo did not show are drawn in, when they are.
pub const NEUTRAL_FILL: f32 = 0.5;

/// Leaves out of `avatar` what its photo did not show: the UV Gaussians on triangles none of
/// whose corners (posed at `vertices`) `camera` sees inside the photo or within [`SEEN_MARGIN`]
/// of its edge ([`seen_within`]) move, greyed, to the end of the UV set (the avatar's `outside`
/// block, drawn only on request), and the template Gaussians on such vertices go transparent. The hands
/// stay, in the colour their part was given: a hand raised into the photo's view is drawn
/// there, with its lower arm where the photo did not show that ([`crate::avatar::HandsInView`]). The legs are kept only inside the photo, not near
/// its edge: below an upper-body photo they hung as sticks in the colours at its bottom edge
/// (the torso's margin is for turned views, which see the body go on past the edge). Returns
/// how many UV Gaussians were left out.
fn leave_out(
    avatar: &mut Avatar,
    body: &BodyModel,
    vertices: &[glam::Vec3],
    camera: &crate::camera::Camera,
    shown: Shown,
) -> usize {
    let bounds = [shown.left, shown.top, shown.right, shown.bottom].map(|v| v as f32);
    let hands = crate::avatar::HandsInView::new(avatar, body);
    let seen: Vec<bool> = vertices
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let joint = body.joints[body.dominant_joint(i)].name.as_str();
            let leg = LEG_JOINTS.iter().any(|j| joint.starts_with(j));
            let margin = if leg { 0.0 } else { SEEN_MARGIN };
            body.part_of(i).is_some_and(|p| p.starts_with("hand."))
                || hands.as_ref().is_some_and(|h| h.hides(i))
                || seen_within(camera, bounds, margin, v)
        })
        .collect();
    let outside: Vec<bool> = avatar
        .uv
        .triangles
        .iter()
        .map(|&t| {
            body.triangles[t as usize]
                .iter()
                .all(|&v| !seen[v as usize])
        })
        .collect();
    let c = avatar.channels;
    let order: Vec<usize> = (0..outside.len())
        .filter(|&i| !outside[i])
        .chain((0..outside.len()).filter(|&i| outside[i]))
        .collect();
    let uv = &avatar.uv;
    let mut sorted = crate::avatar::UvGaussians {
        triangles: order.iter().map(|&i| uv.triangles[i]).collect(),
        barycentrics: order.iter().map(|&i| uv.barycentrics[i]).collect(),
        offsets: order.iter().map(|&i| uv.offsets[i]).collect(),
        local: crate::avatar::LocalGaussians {
            rotations: order.iter().map(|&i| uv.local.rotations[i]).collect(),
            scales: order.iter().map(|&i| uv.local.scales[i]).collect(),
            opacities: order.iter().map(|&i| uv.local.opacities[i]).collect(),
            features: order
                .iter()
                .flat_map(|&i| uv.local.features[i * c..(i + 1) * c].iter().copied())
                .collect(),
        },
    };
    let left_out = outside.iter().filter(|&&o| o).count();
    let first = order.len() - left_out;
    for f in sorted.local.features[first * c..].chunks_exact_mut(c) {
        f[..3].fill(NEUTRAL_FILL);
        f[3..].fill(0.0);
    }
    avatar.uv = sorted;
    avatar.outside = left_out;
    for (v, opacity) in avatar.template.opacities.iter_mut().enumerate() {
        if !seen[v] {
            *opacity = 0.0;
        }
    }
    left_out
}
