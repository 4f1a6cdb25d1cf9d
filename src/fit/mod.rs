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
mod report;
mod silhouette;
mod unknowns;

pub use face::{FACE_FEATURES, FACE_FIT_POINTS, FaceEmbedding, embed_face};
pub use gaze::{eye_joint, pupil};
pub use hand::{BodyPoint, hand_targets};
pub use report::{FaceFitReport, FitReport, GazeFitReport, HandFitReport};
pub use silhouette::{SilhouetteReport, fit_silhouette};

use problem::{Stage, State, Target, Unknown, camera_for};
use unknowns::{
    face_joints, face_shapes, fitted_expressions, joint_unknowns, relaxed_pose, root_and_camera,
};

use glam::{Vec2, Vec3};

use crate::body::{BodyModel, EhmModel, HEAD_SIZE, Landmark, PointPoser, TargetGroup};
use crate::camera::GUAVA_INVTANFOV;
use crate::keypoints::{
    Detections, FACE_EYE_CORNERS, FaceLandmarker, FaceLandmarks, HandLandmarks, Iris, Keypoint,
};
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
/// Below this pose presence the pose model sees no person (MediaPipe's tracking threshold), and
/// its landmarks, confident-looking or not, are not fitted.
pub const MIN_PRESENCE: f32 = 0.5;
/// Keypoints the model is less sure of are left out.
pub const MIN_CONFIDENCE: f32 = 0.5;
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
const ITERATIONS: usize = 30;
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
    // Without a body from the pose model (no person, or points that contradict the face: a
    // photo framed tighter than GUAVA's), the head and shoulders from the face mesh and the
    // person mask, or no fit.
    let presence = detections.pose.presence;
    let no_body = if presence.is_nan() || presence < MIN_PRESENCE {
        Some(format!("the pose model's presence is {presence:.2}"))
    } else {
        detections
            .face
            .as_ref()
            .and_then(|face| head_and_shoulders::contradicts(&detections.pose.keypoints, face))
    };
    let from_face = match &no_body {
        Some(_) => {
            let points = detections.face.as_ref().and_then(|face| {
                head_and_shoulders::keypoints_from_face(
                    body,
                    face,
                    &detections.pose.mask_at(side as usize),
                    side,
                )
            });
            Some(points.ok_or(FitError::NoPerson { presence })?)
        }
        None => None,
    };
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
        keypoints: from_face.as_deref().unwrap_or(&detections.pose.keypoints),
        face,
        hands: &detections.hands,
        irises: &detections.irises,
    };
    let (view, mut report) = fit_keypoints(body, &input, side)?;
    report.face_skipped = embedding.err();
    report.body_from_face = no_body;
    Ok((view, report))
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

/// Fits the default body to what `input` holds (body keypoints; the face mesh and hands when
/// given) in a `side`² image seen by GUAVA's camera; returns the source view (pose and camera)
/// for reconstruction.
pub fn fit_keypoints(
    body: &BodyModel,
    input: &FitInput,
    side: u32,
) -> Result<(SourceView, FitReport), FitError> {
    let (keypoints, face) = (input.keypoints, input.face);
    let landmark = |name: &str| body.landmarks.iter().position(|l| l.name == name);
    let mut observations = Vec::new();
    let mut names = Vec::new();
    let mut surface = Vec::new();
    for k in keypoints.iter().filter(|k| k.confidence >= MIN_CONFIDENCE) {
        let l = landmark(k.name).ok_or_else(|| FitError::MissingOnBody(k.name.into()))?;
        let weight = if k.name.ends_with("_hip") {
            HIP_WEIGHT
        } else {
            1.0
        };
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
    let start_at = |depth: f32| State {
        feature_offsets: [Vec2::ZERO; FACE_FEATURES.len()],
        pose: relaxed.clone(),
        camera: Vec3::new(
            (m2.x - centre) * depth / focal - m3.x,
            (m2.y - centre) * depth / focal + m3.y,
            depth + m3.z,
        ),
    };
    let camera_step = 1e-4 * depth as f64;

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

    let mut unknowns: Vec<(Unknown, f64)> = root_and_camera().collect();
    for name in FITTED_JOINTS {
        // A leg turns only where the keypoint at its far end was seen: otherwise the hip points
        // alone (skinned to the thighs) lifted the demo portrait's thigh 57° toward the camera.
        let far_end = match name {
            "upperleg01.L" => Some("left_knee"),
            "upperleg01.R" => Some("right_knee"),
            "lowerleg01.L" => Some("left_ankle"),
            "lowerleg01.R" => Some("right_ankle"),
            _ => None,
        };
        if far_end.is_some_and(|k| !has(k)) {
            continue;
        }
        let j = joint(name)?;
        unknowns.extend(joint_unknowns(body, j));
    }
    unknowns.extend(
        body.targets_in(TargetGroup::Shape)
            .map(|(i, t)| (Unknown::Coefficient(i, t.range), SHAPE_PRIOR_PX)),
    );
    let body_observed = observations.len();
    let mut stage = Stage {
        body,
        side,
        poser: &mut poser,
        observations,
        unknowns,
        antagonists: Vec::new(),
        features: vec![None; body_observed],
        pixels: Vec::new(),
        base: start_at(depth),
        relaxed: relaxed.clone(),
        points: Vec::new(),
        joints: Vec::new(),
    };
    // The body stage has several minima (a broad suit's shoulders fit a short, large-headed body
    // too), and which one a single start reaches changes with the last bits of the keypoints or
    // of the maths library: start from several depths around the shoulder-width estimate and
    // keep the best.
    let (mut best, mut iterations) = ((stage.base.clone(), f64::INFINITY), 0);
    for factor in BODY_START_DEPTHS {
        stage.base = start_at(factor * depth);
        let (state, used, cost) = stage.solve(camera_step);
        iterations += used;
        if cost < best.1 {
            best = (state, cost);
        }
    }
    let mut result = best.0;

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
        let eye_span =
            landmarks.points[FACE_EYE_CORNERS.0].distance(landmarks.points[FACE_EYE_CORNERS.1]);
        let expression_prior = EXPRESSION_PRIOR_PER_EYE_SPAN * eye_span as f64;
        unknowns.extend(fitted_expressions(body).map(|i| {
            (
                Unknown::Coefficient(i, body.targets[i].range),
                expression_prior,
            )
        }));
        unknowns.extend(face_shapes(body).map(|t| {
            (
                Unknown::Coefficient(t, body.targets[t].range),
                SHAPE_PRIOR_PX,
            )
        }));
        for g in 0..FACE_FEATURES.len() {
            unknowns.extend((0..2).map(|k| (Unknown::FeatureOffset(g, k), FEATURE_OFFSET_PRIOR)));
        }
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
        let mut unknowns = Vec::new();
        for (h, targets) in input.hands.iter().zip(&hand_targets) {
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
            for j in hand::hand_joints(body, h.side)? {
                let prior = FINGER_PRIOR_PER_PALM * palm;
                unknowns.extend((0..3).map(|k| (Unknown::Joint(j, k), prior)));
            }
        }
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
        rms_px: stage.rms(&result, 0..body_observed),
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
        hands: hands_report,
        gaze: gaze_report,
    };
    Ok((
        SourceView {
            pose: result.pose,
            camera: camera_for(result.camera, side),
            crop: None,
        },
        report,
    ))
}
