//! Pairs for training and judging the default refiner, made by the project itself: synthetic
//! subjects ([`Subject`]: bare, in a jacket, with hair, both) in textures drawn from a seed
//! ([`seeded_texture`]), each photographed from the front and reconstructed in default mode; then
//! from other views and in other poses, the avatar through the splatting pass (the refiner's
//! input) beside the subject itself drawn antialiased (the target).
//!
//! Training and held-out pairs share nothing: held-out subjects have their own seeds, are seen
//! from yaws the training never uses (±30°, ±60°) and in poses from the demo motion's second half
//! (training poses come from its first half). Those are new textures on the four training
//! bodies, and a third of their views are the rest pose; [`Split::UnseenBodies`] holds out the
//! body too (shapes the training never saw: heavier and shorter, taller with other proportions)
//! and shows it only in poses from the motion's second half.

use glam::Vec3;

use crate::body::{BodyModel, BodyPose, Posable, PoseError};
use crate::camera::{Camera, GUAVA_INVTANFOV};
use crate::eval::metrics::{Metrics, compare, person_box};
use crate::eval::subjects::{SubjectError, front_view, reconstruct_subject_as};
use crate::eval::{interleaved_rgb, render_view};
use crate::pipeline::Pipeline;
use crate::render::{HeadlessRenderer, SplatImage};
use crate::synthetic::{Subject, seeded_texture, upper_body_camera};
use crate::tracking::{Retarget, SourceView, demo_motion};

/// Pairs are drawn at this side (GUAVA's field of view).
pub const SIDE: u32 = 256;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    Train,
    HeldOut,
    /// Held-out seeds on bodies of unseen shape, in unseen poses only.
    UnseenBodies,
}

/// One view of an avatar: yaw and pitch around the chest (degrees), a zoom (1 frames the upper
/// body as GUAVA does), and a time in the demo motion (`None`: the photo's rest pose).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    pub yaw: f32,
    pub pitch: f32,
    pub zoom: f32,
    pub time: Option<f64>,
}

/// A subject kind, its texture seed and the views it is drawn from.
#[derive(Clone, Debug)]
pub struct AvatarSpec {
    pub kind: usize,
    pub seed: u64,
    pub views: Vec<View>,
    /// The body's shape: morph targets of the default body and their coefficients (none: its
    /// default phenotype, as in training).
    pub shape: Vec<(&'static str, f32)>,
}

/// The four subject kinds, by index.
pub const KINDS: [&str; 4] = ["bare", "clothed", "haired", "clothed and haired"];

fn subject(kind: usize, body: &BodyModel) -> Subject<'_> {
    match kind {
        0 => Subject::bare(body),
        1 => Subject::clothed(body),
        2 => Subject::haired(body),
        _ => Subject::clothed_and_haired(body),
    }
}

/// Training: seeds 1–16 of each kind, 12 views each drawn from yaws 0, ±10, ±20, ±45, ±75, ±90,
/// pitches −10, 0, 10, zooms 0.8, 1, 1.25 and the rest pose or the demo motion's first 4 s.
/// Held out: seeds 1001–1002 of each kind at yaws ±30, ±60 in the rest pose, the wave (6.45 s)
/// and 5.2 s.
pub fn specs(split: Split) -> Vec<AvatarSpec> {
    let mut out = Vec::new();
    match split {
        Split::Train => {
            const YAWS: [f32; 11] = [
                0.0, 10.0, -10.0, 20.0, -20.0, 45.0, -45.0, 75.0, -75.0, 90.0, -90.0,
            ];
            const PITCHES: [f32; 3] = [-10.0, 0.0, 10.0];
            const ZOOMS: [f32; 3] = [0.8, 1.0, 1.25];
            let mut state = 0x5EED_u64;
            let mut pick = |n: usize| {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                ((state >> 33) as usize) % n
            };
            for seed in 1..=16u64 {
                for kind in 0..KINDS.len() {
                    let views = (0..12)
                        .map(|_| View {
                            yaw: YAWS[pick(YAWS.len())],
                            pitch: PITCHES[pick(PITCHES.len())],
                            zoom: ZOOMS[pick(ZOOMS.len())],
                            time: match pick(5) {
                                0 => None,
                                k => Some(k as f64 * 0.8 - 0.3 + pick(4) as f64 * 0.1),
                            },
                        })
                        .collect();
                    out.push(AvatarSpec {
                        kind,
                        seed,
                        views,
                        shape: Vec::new(),
                    });
                }
            }
        }
        Split::HeldOut => {
            for seed in [1001u64, 1002] {
                for kind in 0..KINDS.len() {
                    let mut views = Vec::new();
                    for yaw in [30.0, -30.0, 60.0, -60.0] {
                        for time in [None, Some(6.45), Some(5.2)] {
                            views.push(View {
                                yaw,
                                pitch: 0.0,
                                zoom: 1.0,
                                time,
                            });
                        }
                    }
                    out.push(AvatarSpec {
                        kind,
                        seed,
                        views,
                        shape: Vec::new(),
                    });
                }
            }
        }
        Split::UnseenBodies => {
            let shapes: [Vec<(&'static str, f32)>; 2] = [
                vec![
                    ("weight_max", 0.8),
                    ("muscle_max", 0.4),
                    ("height_min", 0.6),
                ],
                vec![
                    ("height_max", 0.7),
                    ("proportions_max", 0.9),
                    ("gender_max", 0.5),
                ],
            ];
            for (seed, shape) in [2001u64, 2002].into_iter().zip(shapes) {
                for kind in 0..KINDS.len() {
                    let mut views = Vec::new();
                    for yaw in [30.0, -30.0, 60.0, -60.0] {
                        for time in [6.45, 5.2, 7.3] {
                            views.push(View {
                                yaw,
                                pitch: 0.0,
                                zoom: 1.0,
                                time: Some(time),
                            });
                        }
                    }
                    out.push(AvatarSpec {
                        kind,
                        seed,
                        views,
                        shape: shape.clone(),
                    });
                }
            }
        }
    }
    out
}

/// The rest pose of `spec`'s body: its shape coefficients set.
fn rest_of(body: &BodyModel, spec: &AvatarSpec) -> Result<BodyPose, PoseError> {
    let mut rest = BodyPose::rest(body);
    for &(name, value) in &spec.shape {
        let i = body
            .parameter_names()
            .position(|n| n == name)
            .ok_or_else(|| PoseError::UnknownParameter(name.into()))?;
        rest.coefficients[i] = value;
    }
    Ok(rest)
}

/// A refiner pair: what the splatting pass gives, and the truth.
pub struct Pair {
    /// The avatar rendered on black: RGB, source confidence, alpha.
    pub input: SplatImage,
    /// The subject drawn antialiased: RGB premultiplied by its coverage, on black.
    pub target_rgb: Vec<f32>,
    /// Its coverage (alpha).
    pub target_alpha: Vec<f32>,
}

impl Pair {
    /// `input` beside `truth` (straight alpha, as [`Subject::photo`] draws it), the same size.
    pub fn new(input: SplatImage, truth: &image::RgbaImage) -> Self {
        let n = truth.width() as usize * truth.height() as usize;
        let (mut target_rgb, mut target_alpha) = (vec![0.0; 3 * n], vec![0.0; n]);
        for (i, p) in truth.pixels().enumerate() {
            let a = f32::from(p[3]) / 255.0;
            target_alpha[i] = a;
            for c in 0..3 {
                target_rgb[c * n + i] = f32::from(p[c]) / 255.0 * a;
            }
        }
        Self {
            input,
            target_rgb,
            target_alpha,
        }
    }

    /// How `image` (the input, or the refiner's output) compares with the truth, as
    /// `guava eval` compares: silhouette IoU, and PSNR, SSIM and L1 over the subject's box.
    /// `None` when the subject is not in view.
    pub fn score(&self, image: &SplatImage) -> Option<Metrics> {
        let size = image.width as usize;
        let bounds = person_box(&self.target_alpha, size)?;
        let n = size * size;
        let truth: Vec<f32> = (0..n)
            .flat_map(|i| std::array::from_fn::<f32, 3, _>(|c| self.target_rgb[c * n + i]))
            .collect();
        Some(compare(
            &interleaved_rgb(image),
            &image.alpha,
            &truth,
            &self.target_alpha,
            size,
            bounds,
        ))
    }
}

/// The camera of `view` at `side`² (pairs use [`SIDE`]).
pub fn camera(body: &BodyModel, view: &View, side: u32) -> Camera {
    let front = upper_body_camera(body, 0.0);
    let eye = front.view_from_world.inverse().transform_point3(Vec3::ZERO);
    let target = Vec3::new(0.0, eye.y, 0.0);
    let distance = (eye - target).length() / view.zoom;
    let (yaw, pitch) = (view.yaw.to_radians(), view.pitch.to_radians());
    let dir = Vec3::new(
        yaw.sin() * pitch.cos(),
        pitch.sin(),
        yaw.cos() * pitch.cos(),
    );
    Camera::guava(
        Camera::look_at(target + distance * dir, target, Vec3::Y),
        side,
        GUAVA_INVTANFOV,
    )
}

/// Reconstructs `spec`'s subject from its front photo and hands each of its views' pairs to
/// `each`.
pub fn make(
    renderer: &mut HeadlessRenderer,
    pipeline: &mut Pipeline,
    body: &BodyModel,
    spec: &AvatarSpec,
    each: &mut dyn FnMut(&View, Pair),
) -> Result<(), SubjectError> {
    let subject = subject(spec.kind, body);
    let texture = seeded_texture(spec.seed);
    let rest = rest_of(body, spec)?;
    let outcome =
        reconstruct_subject_as(pipeline, &subject, &texture, front_view(body, rest.clone()))?;
    let motion = demo_motion()?;
    let retarget = Retarget::new(&motion, body);
    for view in &spec.views {
        let mut pose = rest.clone();
        if let Some(t) = view.time {
            retarget.sample(&motion, t, &mut pose);
        }
        let at = SourceView {
            pose,
            camera: camera(body, view, SIDE),
            crop: None,
        };
        let input = render_view(renderer, &outcome.avatar, body, &at)?;
        let truth = subject.photo(&at.pose, &at.camera, &texture)?;
        each(view, Pair::new(input, &truth));
    }
    Ok(())
}
