//! Single-image fitting: the camera, body pose, shape, facial expression and fingers of a body
//! template (the default body, or EHM through its linear form, [`fit_ehm_detections`]) that put
//! its points on a photo's 2D keypoints (Levenberg–Marquardt with priors).
//!
//! Four stages, each posing only the points it observes ([`PointPoser`]). **Body:** the global
//! orientation (root axis-angle), the camera translation (GUAVA's camera: `invtanfov` 24, looking
//! at the body's front, so its distance sets the scale), the rotations of [`FITTED_JOINTS`] and
//! the shape coefficients (within their ranges), against the pose model's body keypoints.
//! **Face**, when the face model found a face: head and neck, the [`FITTED_EXPRESSIONS`] (on a
//! body without ARKit units, its expression components and its jaw joint), the head's shape
//! (the shape targets that leave the limbs in place: [`HEAD_SIZE`] on the default body, FLAME's
//! shape on EHM) and a small image offset per facial feature, against
//! the face mesh's points on the body ([`FaceEmbedding`]), the body keypoints kept in.
//! **Hands**, for each hand found: forearm, wrist and fingers against its 21 points
//! ([`hand_targets`]). **Gaze**, after the face stage, for each iris found: the eye joint
//! against the iris centre (the body's pupil moved by its eye's feature offset, so the gaze is
//! the iris's place within the eye, not the eye's place in the face). Residuals are
//! reprojection errors in pixels, weighted by √confidence; priors pull joints to rest at
//! [`PRIOR_PX_PER_RAD`] pixels per radian, shape to the default at [`SHAPE_PRIOR_PX`],
//! expressions to neutral at [`EXPRESSION_PRIOR_PER_EYE_SPAN`] per unit and fingers to rest in
//! proportion to the palm, so what no keypoint constrains stays put.

mod face;
mod gaze;
mod hand;
mod head_and_shoulders;
mod lm;
mod problem;
mod reach;
mod report;
mod silhouette;
mod unknowns;

pub use face::{FACE_FEATURES, FACE_FIT_POINTS, FaceEmbedding, embed_face};
pub use gaze::{eye_joint, pupil};
pub use hand::{BodyPoint, hand_targets};
pub use reach::Arm;
pub use report::{FaceFitReport, FitReport, GazeFitReport, HandFitReport};
pub use silhouette::{SilhouetteReport, fit_silhouette};

pub use problem::{FitState, camera_for};
use problem::{Stage, Target, Unknown};
use unknowns::{
    face_joints, face_shapes, fitted_expressions, joint_unknowns, relaxed_pose, root_and_camera,
};

use glam::{Vec2, Vec3};

use crate::body::{BodyModel, EhmModel, HEAD_SIZE, Landmark, PointPoser, TargetGroup};
use crate::camera::GUAVA_INVTANFOV;
use crate::keypoints::{
    Detections, FACE_EYE_CORNERS, FaceLandmarker, FaceLandmarks, HandLandmarks, Iris, Keypoint,
    Side,
};
pub use crate::keypoints::{MIN_CONFIDENCE, MIN_PRESENCE, no_body};
use crate::tracking::SourceView;

/// The joints the body stage turns (besides the root).
pub const FITTED_JOINTS: [&str; 13] = [
    "spine03",
    "clavicle.L",
    "clavicle.R",
    "neck01",
    "head",
    "upperarm01.L",
    "upperarm01.R",
    "lowerarm01.L",
    "lowerarm01.R",
    "upperleg01.L",
    "upperleg01.R",
    "lowerleg01.L",
    "lowerleg01.R",
];
/// The face units the face stage fits: those 2D face points tell apart. The other ARKit units
/// (stretch, press, dimple, roll, shrug, jaw sideways, gaze…) mostly re-describe the same point
/// motions and, on a real face, soak up how the person's face differs from the default body's;
/// they stay neutral.
pub const FITTED_EXPRESSIONS: [&str; 14] = [
    "jawOpen",
    "mouthSmileLeft",
    "mouthSmileRight",
    "mouthFrownLeft",
    "mouthFrownRight",
    "mouthFunnel",
    "mouthPucker",
    "eyeBlinkLeft",
    "eyeBlinkRight",
    "browInnerUp",
    "browDownLeft",
    "browDownRight",
    "browOuterUpLeft",
    "browOuterUpRight",
];
/// The joints the face stage turns again, with the expression; and the jaw, on a body whose
/// mouth opens by its jaw joint rather than an ARKit `jawOpen` unit (EHM: FLAME's jaw).
const FACE_JOINTS: [&str; 2] = ["neck01", "head"];
const JAW_JOINT: &str = "jaw";
/// The person's face is not the default body's: the face stage shapes the body's head to it (its
/// [`face_shapes`]: the default body's [`HEAD_SIZE`], EHM's FLAME shape components; so texture
/// mapping sees the face where the photo has it) and
/// lets each feature (lips, eyes, brows, nose) sit a little apart in the image from where the
/// default face has it, so that expressions explain how features are shaped, not where they are.
/// An offset pixel costs this fraction of one point's pixel.
const FEATURE_OFFSET_PRIOR: f64 = 0.3;
/// Units that pull the same points opposite ways: on a real face, whose neutral differs from
/// the default body's, both can rise together to widen or shift a feature, so they pay for acting
/// at once (a residual of their product).
const ANTAGONISTS: [(&str, &str); 4] = [
    ("mouthSmileLeft", "mouthFrownLeft"),
    ("mouthSmileRight", "mouthFrownRight"),
    ("browDownLeft", "browOuterUpLeft"),
    ("browDownRight", "browOuterUpRight"),
];
/// Both antagonists at 1 cost as much as one face point off by this fraction of the eye span.
const ANTAGONIST_PER_EYE_SPAN: f64 = 1.0;
/// Prior strength: a joint turned by 1 rad costs as much as a keypoint 25 px off.
pub const PRIOR_PX_PER_RAD: f64 = 25.0;
/// Shape prior: a shape coefficient at 1 (a phenotype's end) costs as much as a keypoint 20 px off.
pub const SHAPE_PRIOR_PX: f64 = 20.0;
/// Expression prior: a face unit at 1 costs as much as one face point off by this fraction of the
/// face's outer-eye-corner distance (so it does not depend on how many pixels the face covers).
/// Weak, because a unit moves a dozen points at once; it keeps units no point sees at neutral.
pub const EXPRESSION_PRIOR_PER_EYE_SPAN: f64 = 0.03;
/// In a video's later frames points fade in from this confidence on (full weight at
/// 2·[`MIN_CONFIDENCE`] − this).
const WARM_CONFIDENCE: f32 = 0.3;
/// Hand points count like face points; finger joints turned by 1 rad cost as much as a point off
/// by this fraction of the palm (wrist to middle knuckle), so the prior scales with the hand.
const HAND_POINT_WEIGHT: f64 = 0.5;
const FINGER_PRIOR_PER_PALM: f64 = 0.1;
/// The face mesh's ~100 points are not independent observations: each counts at this weight.
const FACE_POINT_WEIGHT: f64 = 0.5;
/// An eye turned by 1 rad costs as much as an iris centre off by this fraction of the face's
/// outer-eye-corner distance: weak beside what the iris shows (an eyeball's radius is about an
/// eighth of that distance per radian), so the gaze follows the iris.
const GAZE_PRIOR_PER_EYE_SPAN: f64 = 0.02;
/// The hips count at this weight. In an upper-body photo they are below the frame or at its
/// edge, where the pose model guesses, and confidently: on the demo portrait MediaPipe put them on
/// the chest, and on the drawn body (hips in view) 85–90 px above the body's COCO hips, more than
/// half the way up to the shoulders. At full weight they were the reason the fit leaned the
/// torso back (a shorter torso in the picture); at ¼ the drawn body's joints come within 7.9 px
/// mean of the truth (tests/fit.rs) and the cameraman's legs still hang from where his hips are.
const HIP_WEIGHT: f64 = 0.25;
/// A photo's legs are posed only when a knee is seen at this confidence (a full-body photo).
const LEGS_SEEN: f32 = 0.8;
/// The legs' joints the body stage turns, each with the keypoint at its far end.
const LEGS: [(&str, &str); 4] = [
    ("upperleg01.L", "left_knee"),
    ("upperleg01.R", "right_knee"),
    ("lowerleg01.L", "left_ankle"),
    ("lowerleg01.R", "right_ankle"),
];
const ITERATIONS: usize = 30;
/// A video frame's fit starts where the last one ended: a few iterations a stage suffice.
const WARM_ITERATIONS: usize = 6;
/// How strongly a video frame's fit is pulled to the last frame's values (at 30 fps; the
/// tracker scales them by its frame rate): a joint turned by 1 rad since then costs as much as
/// a keypoint this many pixels off, …
const TEMPORAL_PX_PER_RAD: f64 = 40.0;
/// … the camera moved as much as this share of the pixels a sideways move shifts the body by,
/// …
const TEMPORAL_CAMERA_SHARE: f64 = 0.5;
/// … a face unit changed by 1 as much as a face point off by this fraction of the eye span, an
/// eye turned by 1 rad this fraction, and a finger joint turned by 1 rad this fraction of the
/// palm.
const TEMPORAL_EXPRESSION_PER_EYE_SPAN: f64 = 0.3;
const TEMPORAL_GAZE_PER_EYE_SPAN: f64 = 0.1;
const TEMPORAL_FINGER_PER_PALM: f64 = 0.3;
/// In a video, the root and the torso's joints are also pulled to their first frame's turn: a
/// turn of 1 rad from it costs as much as a keypoint this many pixels off.
const ANCHOR_PX_PER_RAD: f64 = 25.0;
/// The torso's joints the anchor holds (besides the root).
const TORSO_JOINTS: [&str; 1] = ["spine03"];

/// Starting depths of the body stage, as factors of the shoulder-width estimate.
const BODY_START_DEPTHS: [f32; 3] = [0.85, 1.0, 1.2];

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FitError {
    #[error(
        "no person found: the pose model's presence is {presence:.2} (it needs {MIN_PRESENCE}); its points would be guesses"
    )]
    NoPerson { presence: f32 },
    #[error(
        "only {found} confident body keypoints ({names}); the fit needs both shoulders and at least 4 in all"
    )]
    TooFewKeypoints { found: usize, names: String },
    #[error("the body has no landmark or joint named {0:?}")]
    MissingOnBody(String),
    #[error("face model: {0}")]
    FaceModel(String),
}

/// Fits the body to what the keypoint models found on a photo: body keypoints, and the face mesh
/// when there is one (placed on the body by [`embed_face`] with `face_model`). A face that cannot
/// be used leaves the fit to the body keypoints and says why in [`FitReport::face_skipped`].
pub fn fit_detections(
    body: &BodyModel,
    detections: &Detections,
    face_model: &mut FaceLandmarker,
    side: u32,
) -> Result<(SourceView, FitReport), FitError> {
    let (keypoints, no_body) = body_keypoints(body, detections, side)?;
    let embedding = detections
        .face
        .as_ref()
        .ok_or_else(|| {
            "the face model found no face (or the pose model saw no eyes and nose)".to_string()
        })
        .and_then(|_| embed_face(body, face_model).map_err(|e| e.to_string()));
    let face = match (&detections.face, &embedding) {
        (Some(f), Ok(e)) => Some((f, e)),
        _ => None,
    };
    let input = FitInput {
        keypoints: &keypoints,
        face,
        hands: &detections.hands,
        irises: &detections.irises,
    };
    let (view, mut report) = fit_keypoints(body, &input, side)?;
    report.face_skipped = embedding.err();
    report.body_from_face = no_body;
    Ok((view, report))
}

/// The body keypoints a fit uses of what the models found on a photo (or a video's frame): the
/// pose model's, or — when it sees no person, or its points contradict the face (a photo framed
/// tighter than GUAVA's: a face close up, where the pose model put the shoulders beside the
/// nose) — the head's and shoulders' from the face mesh and the person mask; with why the pose
/// model's were not used. No face then: no fit.
pub fn body_keypoints<'a>(
    body: &BodyModel,
    detections: &'a Detections,
    side: u32,
) -> Result<(std::borrow::Cow<'a, [Keypoint]>, Option<String>), FitError> {
    let presence = detections.pose.presence;
    let no_body = no_body(&detections.pose, detections.face.as_ref());
    let from_face = || {
        detections.face.as_ref().and_then(|face| {
            head_and_shoulders::keypoints_from_face(
                body,
                face,
                |pixel| detections.pose.mask_value(pixel),
                side,
            )
        })
    };
    let Some(why) = no_body else {
        // A shoulder the pose model is unsure of (below the frame's edge in a head and
        // shoulders shot: a third of such a video's frames) is placed from the face, as the
        // whole body is when the pose model sees none.
        let pose = &detections.pose.keypoints;
        let unsure = |k: &Keypoint| k.name.ends_with("_shoulder") && k.confidence < MIN_CONFIDENCE;
        if pose.iter().any(unsure)
            && let Some(face) = from_face()
        {
            let points = pose
                .iter()
                .map(|k| match unsure(k) {
                    true => *face.iter().find(|f| f.name == k.name).unwrap_or(k),
                    false => *k,
                })
                .collect::<Vec<_>>();
            let why = "the pose model was unsure of a shoulder: placed from the face".into();
            return Ok((points.into(), Some(why)));
        }
        return Ok((pose.as_slice().into(), None));
    };
    let points = from_face().ok_or(FitError::NoPerson { presence })?;
    Ok((points.into(), Some(why)))
}

/// [`fit_detections`] for GUAVA's body: fits EHM's linear form ([`EhmModel::linearised`]) and
/// returns the view as a pose of EHM itself.
pub fn fit_ehm_detections(
    body: &EhmModel,
    detections: &Detections,
    face_model: &mut FaceLandmarker,
    side: u32,
) -> Result<(SourceView, FitReport), FitError> {
    let linear = body.linearised();
    let (view, report) = fit_detections(&linear, detections, face_model, side)?;
    let pose = body
        .pose_from_linear(&linear, &view.pose)
        .expect("the linear body's pose has its lengths and EHM's parameter names");
    Ok((
        SourceView {
            pose,
            camera: view.camera,
            crop: None,
        },
        report,
    ))
}

/// What the fit sees on a photo.
pub struct FitInput<'a> {
    pub keypoints: &'a [Keypoint],
    /// The face mesh with the body's embedding of it.
    pub face: Option<(&'a FaceLandmarks, &'a FaceEmbedding)>,
    pub hands: &'a [HandLandmarks],
    /// Irises in the face's eyes; used only with the face.
    pub irises: &'a [Iris],
}

impl<'a> FitInput<'a> {
    /// Body keypoints only.
    pub fn body(keypoints: &'a [Keypoint]) -> Self {
        Self {
            keypoints,
            face: None,
            hands: &[],
            irises: &[],
        }
    }
}

/// How a fit starts.
#[derive(Clone, Copy, Debug)]
pub enum Start<'a> {
    /// A photo: from rest, from several starting depths, the shape free.
    Cold,
    /// The next frame of a video: from the last frame's state, the identity (shape, head shape,
    /// the facial features' offsets) kept, [`WARM_ITERATIONS`] a stage, every unknown pulled
    /// to where it was at `temporal` times the [`TEMPORAL_PX_PER_RAD`] family of weights, and
    /// the torso's turn to where the video's first frame (`anchor`) had it
    /// ([`ANCHOR_PX_PER_RAD`]).
    Warm {
        previous: &'a FitState,
        anchor: &'a FitState,
        temporal: f64,
    },
}

/// Fits the default body to what `input` holds (body keypoints; the face mesh and hands when
/// given) in a `side`² image seen by GUAVA's camera; returns the source view (pose and camera)
/// for reconstruction.
pub fn fit_keypoints(
    body: &BodyModel,
    input: &FitInput,
    side: u32,
) -> Result<(SourceView, FitReport), FitError> {
    let (state, report) = fit_from(body, input, side, Start::Cold)?;
    let view = SourceView {
        camera: state.camera(side),
        pose: state.pose,
        crop: None,
    };
    Ok((view, report))
}

/// The fit of a video's next frame, started from the last one's `previous` state, its torso
/// held near the first frame's `anchor` ([`Start::Warm`]); `temporal` scales the pull towards
/// the last frame (1 at 30 frames a second).
pub fn fit_frame(
    body: &BodyModel,
    input: &FitInput,
    side: u32,
    previous: &FitState,
    anchor: &FitState,
    temporal: f64,
) -> Result<(FitState, FitReport), FitError> {
    let start = Start::Warm {
        previous,
        anchor,
        temporal,
    };
    fit_from(body, input, side, start)
}

/// [`fit_keypoints`] and [`fit_frame`]: the body, face, gaze and hand stages from `start`.
fn fit_from(
    body: &BodyModel,
    input: &FitInput,
    side: u32,
    start: Start,
) -> Result<(FitState, FitReport), FitError> {
    let (keypoints, face) = (input.keypoints, input.face);
    let landmark = |name: &str| body.landmarks.iter().position(|l| l.name == name);
    let mut observations = Vec::new();
    let mut names = Vec::new();
    let mut surface = Vec::new();
    // A video's later frames leave out the lower body's points: in an upper-body video the
    // pose model guesses the hips, knees and ankles at the frame's lower edge, confidently,
    // and frame after frame they drew the camera away (the first frame's silhouette stage,
    // which sets the torso's length, is not run again).
    let warm_start = matches!(start, Start::Warm { .. });
    let lower_body = |name: &str| {
        ["_hip", "_knee", "_ankle"]
            .iter()
            .any(|end| name.ends_with(end))
    };
    // A photo's points count from MIN_CONFIDENCE on. A video's fade in between
    // WARM_CONFIDENCE and MIN_CONFIDENCE + that span: a point whose confidence wavers about
    // the threshold (an elbow at the frame's edge) would otherwise come and go, and the arm
    // jump with it.
    let fade = |confidence: f32| match warm_start {
        true => ((confidence - WARM_CONFIDENCE) / (2.0 * (MIN_CONFIDENCE - WARM_CONFIDENCE)))
            .clamp(0.0, 1.0),
        false => f32::from(u8::from(confidence >= MIN_CONFIDENCE)),
    };
    let used = keypoints
        .iter()
        .filter(|k| fade(k.confidence) > 0.0 && !(warm_start && lower_body(k.name)));
    for k in used {
        let l = landmark(k.name).ok_or_else(|| FitError::MissingOnBody(k.name.into()))?;
        let weight = if k.name.ends_with("_hip") {
            HIP_WEIGHT
        } else {
            1.0
        } * f64::from(fade(k.confidence));
        observations.push((
            Target::Point(l),
            k.pixel,
            weight * (k.confidence as f64).sqrt(),
        ));
        names.push(k.name);
        surface.push(body.landmarks[l].clone());
    }
    let has = |n: &str| names.contains(&n);
    if observations.len() < 4 || !has("left_shoulder") || !has("right_shoulder") {
        return Err(FitError::TooFewKeypoints {
            found: observations.len(),
            names: names.join(", "),
        });
    }
    let joint = |n: &str| {
        body.joint_index(n)
            .ok_or_else(|| FitError::MissingOnBody(n.into()))
    };

    // Start: rest pose, the camera placing the shoulders' midpoint and width where observed.
    let rest = body.landmark_positions(&body.vertices);
    let (ls, rs) = (landmark("left_shoulder"), landmark("right_shoulder"));
    let (ls, rs) = (ls.expect("checked"), rs.expect("checked"));
    let observed = |l: usize| {
        let of = |o: &&(Target, Vec2, f64)| matches!(o.0, Target::Point(i) if i == l);
        observations.iter().find(of).expect("checked").1
    };
    let (m3, w3) = (0.5 * (rest[ls] + rest[rs]), rest[ls].distance(rest[rs]));
    let (m2, w2) = (
        0.5 * (observed(ls) + observed(rs)),
        observed(ls).distance(observed(rs)),
    );
    let focal = GUAVA_INVTANFOV * side as f32 / 2.0;
    let depth = focal * w3 / w2.max(1.0);
    let centre = side as f32 / 2.0;
    // An arm whose elbow and wrist the models did not see rests along the body.
    let unseen_arms = ["left", "right"]
        .map(|side| !has(&format!("{side}_elbow")) && !has(&format!("{side}_wrist")));
    let relaxed = relaxed_pose(body, unseen_arms);
    let start_at = |depth: f32| FitState {
        feature_offsets: [Vec2::ZERO; FACE_FEATURES.len()],
        pose: relaxed.clone(),
        camera: Vec3::new(
            (m2.x - centre) * depth / focal - m3.x,
            (m2.y - centre) * depth / focal + m3.y,
            depth + m3.z,
        ),
    };
    let (warm, iterations) = match start {
        Start::Cold => (None, ITERATIONS),
        Start::Warm {
            previous,
            anchor,
            temporal,
        } => (Some((previous, anchor, temporal)), WARM_ITERATIONS),
    };
    // The camera's depth: estimated from the shoulders, or where the last frame had it.
    let depth = warm.map_or(depth, |(previous, ..)| previous.camera.z.max(1e-3));
    let camera_step = 1e-4 * depth as f64;
    // Each unknown with where the last frame had it and its pull there (`weight` per unit).
    // The torso's turn is also pulled to the first frame's: with the hips out of the frame and
    // the shoulders at its edge, turning the torso and turning the head back the other way
    // explain a turned face alike, and the demo video's torso drifted 130° in 50 frames. Two
    // pulls on one unknown are one pull to their weighted mean (the same least squares).
    let anchored = |u: Unknown| match u {
        Unknown::Joint(j, _) => {
            j == 0 || TORSO_JOINTS.iter().any(|n| body.joint_index(n) == Some(j))
        }
        _ => false,
    };
    let pull = |unknowns: &[(Unknown, f64)], weight: &dyn Fn(Unknown) -> f64| match warm {
        Some((previous, anchor, temporal)) => unknowns
            .iter()
            .map(|&(u, _)| {
                let (last, w) = (previous.get(u), temporal * weight(u));
                match anchored(u) {
                    true => {
                        let (first, a) = (anchor.get(u), ANCHOR_PX_PER_RAD);
                        let total = w * w + a * a;
                        ((w * w * last + a * a * first) / total, total.sqrt())
                    }
                    false => (last, w),
                }
            })
            .collect(),
        None => Vec::new(),
    };
    let (focal64, depth64) = (f64::from(focal), f64::from(depth));
    // The camera's depth moves the body's points far less than a sideways move does, but a
    // person's distance changes as little between frames, and the keypoints alone leave it
    // loose: it has the same pull.
    let joint_or_camera = |u: Unknown| match u {
        Unknown::Camera(_) => TEMPORAL_CAMERA_SHARE * focal64 / depth64,
        _ => TEMPORAL_PX_PER_RAD,
    };

    // The body's landmarks first, then the face points, then the fingertips, all posed by one
    // poser.
    let face_points: &[Landmark] = face.map_or(&[], |(_, e)| &e.points);
    let hand_targets = input
        .hands
        .iter()
        .map(|h| hand_targets(body, h.side))
        .collect::<Result<Vec<_>, _>>()?;
    let tips = hand_targets.iter().flatten().filter_map(|t| match t {
        BodyPoint::Surface(l) => Some(l),
        BodyPoint::Joint(_) => None,
    });
    // Each iris with its eye joint, and its pupil on the body; a body without them does not fit
    // the gaze.
    let (irises, pupils): (Vec<(&Iris, usize)>, Vec<Landmark>) = match face {
        Some(_) => input
            .irises
            .iter()
            .filter_map(|i| {
                let joint = body.joint_index(gaze::eye_joint(i.side))?;
                Some(((i, joint), gaze::pupil(body, i.side)?))
            })
            .unzip(),
        None => Default::default(),
    };
    let first_pupil = body.landmarks.len() + face_points.len() + tips.clone().count();
    let mut poser = PointPoser::new(
        body,
        body.landmarks
            .iter()
            .chain(face_points)
            .chain(tips)
            .chain(&pupils),
    );

    // Arms no body keypoint shows whose hand was found are the hand stage's to place
    // ([`reach`]): the body stage's priors alone would lower them from where the last frame's
    // hands held them.
    let reaching = input
        .hands
        .iter()
        .enumerate()
        .filter(|(_, h)| unseen_arms[usize::from(h.side == Side::Right)])
        .map(|(k, h)| Ok((k, reach::Arm::of(body, h.side)?)))
        .collect::<Result<Vec<_>, FitError>>()?;
    let mut unknowns: Vec<(Unknown, f64)> = root_and_camera().collect();
    for name in FITTED_JOINTS {
        // A leg turns only where the keypoint at its far end was seen: otherwise the hip points
        // alone (skinned to the thighs) lifted the demo portrait's thigh 57° toward the camera.
        let far_end = LEGS
            .iter()
            .find(|(leg, _)| *leg == name)
            .map(|(_, end)| *end);
        // In a video's later frames the legs stay as its first frame fitted them.
        if far_end.is_some_and(|k| !has(k)) {
            continue;
        }
        let j = joint(name)?;
        if reaching.iter().any(|(_, arm)| arm.turns(j)) {
            continue;
        }
        unknowns.extend(joint_unknowns(body, j));
    }
    // The shape is the person's: fitted on a photo (or a video's first frame) and kept.
    if warm.is_none() {
        unknowns.extend(
            body.targets_in(TargetGroup::Shape)
                .map(|(i, t)| (Unknown::Coefficient(i, t.range), SHAPE_PRIOR_PX)),
        );
    }
    let body_observed = observations.len();
    let temporal = pull(&unknowns, &joint_or_camera);
    let mut stage = Stage {
        body,
        side,
        poser: &mut poser,
        observations,
        unknowns,
        antagonists: Vec::new(),
        temporal,
        iterations,
        features: vec![None; body_observed],
        pixels: Vec::new(),
        base: warm.map_or_else(|| start_at(depth), |(previous, ..)| previous.clone()),
        relaxed: relaxed.clone(),
        points: Vec::new(),
        joints: Vec::new(),
    };
    // The body stage has several minima (a broad suit's shoulders fit a short, large-headed body
    // too), and which one a single start reaches changes with the last bits of the keypoints or
    // of the maths library: start from several depths around the shoulder-width estimate and
    // keep the best. A video's next frame starts where the last one ended.
    let (mut best, mut iterations) = ((stage.base.clone(), f64::INFINITY), 0);
    let starts: &[f32] = match warm {
        Some(_) => &[],
        None => &BODY_START_DEPTHS,
    };
    for factor in starts {
        stage.base = start_at(factor * depth);
        let (state, used, cost) = stage.solve(camera_step);
        iterations += used;
        if cost < best.1 {
            best = (state, cost);
        }
    }
    if warm.is_some() {
        let (state, used, _) = stage.solve(camera_step);
        (best.0, iterations) = (state, used);
    }
    let mut result = best.0;
    // Legs no knee was seen of at LEGS_SEEN rest: in an upper-body photo the pose model
    // guesses knees inside the frame (on the demo portrait, on her forearm at 0.65), and the
    // fit lifted a thigh 57° toward the camera to meet one, a kick seen from the side. The
    // guesses still steer the torso, here and in the silhouette stage: left out, the torso and
    // arms of the demo portrait and the cameraman came out elsewhere, and scored less from
    // their own views (docs/fitting.md).
    let legs_rest = warm.is_none()
        && !keypoints
            .iter()
            .any(|k| k.name.ends_with("_knee") && k.confidence >= LEGS_SEEN);
    if legs_rest {
        for (name, _) in LEGS {
            let j = joint(name)?;
            result.pose.rotations[j] = relaxed.rotations[j];
        }
    }

    let mut face_report = None;
    if let Some((landmarks, embedding)) = face {
        let first = body.landmarks.len();
        stage.observations.extend(
            FACE_FIT_POINTS
                .iter()
                .enumerate()
                .take(embedding.points.len())
                .map(|(k, &i)| {
                    let target = Target::Point(first + k);
                    (target, landmarks.points[i], FACE_POINT_WEIGHT)
                }),
        );
        stage.features.extend(
            (0..embedding.points.len())
                .map(|k| FACE_FEATURES.iter().position(|(_, r)| r.contains(&k))),
        );
        let mut unknowns = Vec::new();
        for j in face_joints(body)? {
            unknowns.extend(joint_unknowns(body, j));
        }
        // In a video's later frames the head's size is known (the first frame fitted it), and
        // its ~100 face points say how far the person is better than the body stage's few
        // points: the camera moves here too. (On a photo the head's size and the camera's
        // distance would trade off.)
        if warm.is_some() {
            unknowns.extend((0..3).map(|k| (Unknown::Camera(k), 0.0)));
        }
        let eye_span =
            landmarks.points[FACE_EYE_CORNERS.0].distance(landmarks.points[FACE_EYE_CORNERS.1]);
        let expression_prior = EXPRESSION_PRIOR_PER_EYE_SPAN * eye_span as f64;
        unknowns.extend(fitted_expressions(body).map(|i| {
            (
                Unknown::Coefficient(i, body.targets[i].reach()),
                expression_prior,
            )
        }));
        // The head's shape and the features' offsets are the person's (identity).
        if warm.is_none() {
            unknowns.extend(face_shapes(body).map(|t| {
                (
                    Unknown::Coefficient(t, body.targets[t].range),
                    SHAPE_PRIOR_PX,
                )
            }));
            for g in 0..FACE_FEATURES.len() {
                unknowns
                    .extend((0..2).map(|k| (Unknown::FeatureOffset(g, k), FEATURE_OFFSET_PRIOR)));
            }
        }
        let expression_pull = TEMPORAL_EXPRESSION_PER_EYE_SPAN * eye_span as f64;
        stage.temporal = pull(&unknowns, &|u| match u {
            Unknown::Coefficient(..) => expression_pull,
            u => joint_or_camera(u),
        });
        stage.unknowns = unknowns;
        let weight = ANTAGONIST_PER_EYE_SPAN * eye_span as f64;
        stage.antagonists = ANTAGONISTS
            .iter()
            .filter_map(|(a, b)| Some((body.target_index(a)?, body.target_index(b)?, weight)))
            .collect();
        stage.base = result.clone();
        let face_range = body_observed..stage.observations.len();
        let rms_before_px = stage.rms(&result, face_range.clone());
        let (with_face, face_iterations, _) = stage.solve(camera_step);
        iterations += face_iterations;
        face_report = Some(FaceFitReport {
            points_used: face_range.len(),
            iterations: face_iterations,
            rms_before_px,
            rms_px: stage.rms(&with_face, face_range.clone()),
            observed: stage.observations[face_range.clone()]
                .iter()
                .map(|o| o.1)
                .collect(),
            head_size: body
                .target_index(HEAD_SIZE)
                .map(|t| with_face.pose.coefficients[t]),
            fitted: {
                let mut body_only = with_face.clone();
                body_only.feature_offsets = Default::default();
                stage.projected(&body_only, face_range)
            },
            surface: embedding.points.clone(),
            feature_offsets: with_face.feature_offsets,
        });
        result = with_face;
    }

    let mut gaze_report = None;
    if let (Some((landmarks, _)), false) = (face, irises.is_empty()) {
        // The irises alone: the body's eye keypoints sit on the eyeballs and would turn with
        // them, while the pose model marks where the eye is, not where it looks.
        let others = (
            std::mem::take(&mut stage.observations),
            std::mem::take(&mut stage.features),
        );
        let eye_span =
            landmarks.points[FACE_EYE_CORNERS.0].distance(landmarks.points[FACE_EYE_CORNERS.1]);
        let mut unknowns = Vec::new();
        for (k, &(iris, j)) in irises.iter().enumerate() {
            stage.observations.push((
                Target::Point(first_pupil + k),
                iris.centre,
                FACE_POINT_WEIGHT,
            ));
            let feature = FACE_FEATURES
                .iter()
                .position(|(name, _)| *name == gaze::eye_feature(iris.side));
            stage.features.push(feature);
            let prior = GAZE_PRIOR_PER_EYE_SPAN * eye_span as f64;
            // Up-down and left-right (the rest frames are world-aligned and the body faces +z);
            // the turn about the line of sight moves no pupil.
            unknowns.extend((0..2).map(|k| (Unknown::Joint(j, k), prior)));
        }
        let gaze_pull = TEMPORAL_GAZE_PER_EYE_SPAN * eye_span as f64;
        stage.temporal = pull(&unknowns, &|_| gaze_pull);
        stage.unknowns = unknowns;
        stage.antagonists.clear();
        stage.base = result.clone();
        let range = 0..stage.observations.len();
        let rms_before_px = stage.rms(&result, range.clone());
        let (with_gaze, gaze_iterations, _) = stage.solve(camera_step);
        iterations += gaze_iterations;
        let mut body_only = with_gaze.clone();
        body_only.feature_offsets = Default::default();
        gaze_report = Some(GazeFitReport {
            sides: irises.iter().map(|(i, _)| i.side).collect(),
            rms_before_px,
            rms_px: stage.rms(&with_gaze, range.clone()),
            observed: irises.iter().map(|(i, _)| i.centre).collect(),
            fitted: stage.projected(&body_only, range),
            pupils,
            turn_rad: irises
                .iter()
                .map(|&(_, j)| with_gaze.pose.rotations[j].length())
                .collect(),
        });
        (stage.observations, stage.features) = others;
        result = with_gaze;
    }

    let mut hands_report = None;
    if !input.hands.is_empty() {
        let start = stage.observations.len();
        let mut tip = body.landmarks.len() + face_points.len();
        let (mut unknowns, mut temporal) = (Vec::new(), Vec::new());
        for (k, (h, targets)) in input.hands.iter().zip(&hand_targets).enumerate() {
            // The hand's first point, the wrist, is observed here.
            let wrist = stage.observations.len();
            for (t, &p) in targets.iter().zip(&h.points) {
                let target = match t {
                    BodyPoint::Joint(j) => Target::Joint(*j),
                    BodyPoint::Surface(_) => {
                        tip += 1;
                        Target::Point(tip - 1)
                    }
                };
                stage.observations.push((target, p, HAND_POINT_WEIGHT));
                stage.features.push(None);
            }
            let palm = h.points[0].distance(h.points[9]).max(1.0) as f64;
            let first = unknowns.len();
            // An arm the body stage left to this hand turns at the shoulder too, and is placed
            // afresh where its wrist is far from the hand's (the hand came into view, or the
            // last frame lost it): no pull to where it was then.
            let mut placed = false;
            if let Some((_, arm)) = reaching.iter().find(|(i, _)| *i == k) {
                let seen = stage.projected(&result, wrist..wrist + 1)[0];
                if seen.distance(h.points[0]) > reach::REPLACE_PALMS * palm as f32
                    && let Some(pose) = arm.place(
                        body,
                        &result.pose,
                        &camera_for(result.camera, side),
                        h.points[0],
                    )
                {
                    (result.pose, placed) = (pose, true);
                }
                unknowns
                    .extend((0..3).map(|k| (Unknown::Joint(arm.shoulder, k), PRIOR_PX_PER_RAD)));
            }
            for j in hand::hand_joints(body, h.side)? {
                let prior = FINGER_PRIOR_PER_PALM * palm;
                unknowns.extend((0..3).map(|k| (Unknown::Joint(j, k), prior)));
            }
            let pull_weight = if placed {
                0.0
            } else {
                TEMPORAL_FINGER_PER_PALM * palm
            };
            temporal.extend(pull(&unknowns[first..], &|_| pull_weight));
        }
        stage.temporal = temporal;
        stage.unknowns = unknowns;
        stage.antagonists.clear();
        stage.base = result.clone();
        let range = start..stage.observations.len();
        let rms_before_px = stage.rms(&result, range.clone());
        let (with_hands, hand_iterations, _) = stage.solve(camera_step);
        iterations += hand_iterations;
        hands_report = Some(HandFitReport {
            hands: input.hands.len(),
            iterations: hand_iterations,
            rms_before_px,
            rms_px: stage.rms(&with_hands, range.clone()),
            observed: stage.observations[range.clone()]
                .iter()
                .map(|o| o.1)
                .collect(),
            fitted: stage.projected(&with_hands, range),
            targets: hand_targets.into_iter().flatten().collect(),
        });
        result = with_hands;
    }
    let report = FitReport {
        keypoints_used: body_observed,
        iterations,
        rms_px: {
            // What the resting legs leave unexplained is not the fit's error.
            let squared: Vec<f32> = stage
                .projected(&result, 0..body_observed)
                .iter()
                .zip(&stage.observations)
                .zip(&names)
                .filter(|(_, name)| !(legs_rest && lower_body(name)))
                .map(|((p, o), _)| p.distance_squared(o.1))
                .collect();
            (squared.iter().sum::<f32>() / squared.len().max(1) as f32).sqrt()
        },
        observed: stage.observations[..body_observed]
            .iter()
            .map(|o| o.1)
            .collect(),
        fitted: stage.projected(&result, 0..body_observed),
        surface,
        face: face_report,
        face_skipped: None,
        body_from_face: None,
        unseen_arms: ["left", "right"]
            .into_iter()
            .zip(unseen_arms)
            .filter_map(|(side, unseen)| unseen.then_some(side))
            .collect(),
        legs_at_rest: legs_rest,
        hands: hands_report,
        gaze: gaze_report,
    };
    Ok((result, report))
}
