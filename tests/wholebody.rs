//! EHM-Tracker's keypoint models (YOLOX + DWPose) through our adapter against EHM-Tracker's own
//! Python pre- and post-processing (`onnxdet.py`, `onnxpose.py`), on stand-in models with the
//! real ones' inputs and outputs (tools/make_dwpose_fixture.py; the real weights are not in any
//! package registry).

use glam::{DVec2, Vec2, Vec3};
use guava::body::{BodyModel, PosedBody};
use guava::fit::fit_detections;
use guava::keypoints::{
    COCO_FROM_MEDIAPIPE, Keypoint, Landmarkers, PersonDetector, Rgb8, SimccLandmarker,
    WHOLEBODY_FILES, Wholebody,
};
use guava::onnx::OnnxRuntime;
use guava::photo::SourceImage;
use guava::tracking::SourceView;
use std::path::{Path, PathBuf};

fn runtime() -> &'static OnnxRuntime {
    OnnxRuntime::load().expect("ONNX Runtime (bash tools/setup.sh installs it)")
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(name)
}

fn models() -> PathBuf {
    data("tests/data/dwpose")
}

fn fixture() -> serde_json::Value {
    let bytes = std::fs::read(models().join("fixture.json")).expect("fixture");
    serde_json::from_slice(&bytes).expect("json")
}

fn portrait() -> SourceImage {
    SourceImage::load(&data("assets/demo_portrait.png")).expect("demo portrait")
}

fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn points(v: &serde_json::Value) -> Vec<Vec2> {
    v.as_array()
        .expect("points")
        .iter()
        .map(|p| {
            let p = floats(p);
            Vec2::new(p[0] as f32, p[1] as f32)
        })
        .collect()
}

/// The 96×96 block averages of an NCHW input, channel-major (the stand-in model sees only these).
fn blocks(input: &[f32], w: usize, h: usize) -> Vec<f64> {
    let mut out = Vec::new();
    for c in 0..3 {
        for by in 0..h / 96 {
            for bx in 0..w / 96 {
                let mut sum = 0.0;
                for y in by * 96..(by + 1) * 96 {
                    for x in bx * 96..(bx + 1) * 96 {
                        sum += input[(c * h + y) * w + x] as f64;
                    }
                }
                out.push(sum / (96.0 * 96.0));
            }
        }
    }
    out
}

fn max_abs(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn person_boxes_match_ehm_trackers_python() {
    let mut detector =
        PersonDetector::load_from(runtime(), &models().join(WHOLEBODY_FILES[0])).expect("yolox");
    let found = detector.detect(&Rgb8::from(&portrait())).expect("runs");
    let expected = fixture()["boxes"].as_array().expect("boxes").clone();
    assert_eq!(found.len(), expected.len(), "{found:?}");
    let off = found
        .iter()
        .zip(&expected)
        .map(|(b, e)| {
            let e = floats(e);
            (0..4)
                .map(|k| (b.corners[k] as f64 - e[k]).abs())
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    println!(
        "person boxes: {} as in Python, corners within {off:.2e} px",
        found.len()
    );
    // The letterboxed input is OpenCV's to the bit; what is left is float rounding.
    assert!(off < 1e-3, "{off}");
}

#[test]
fn dwpose_crops_and_points_match_ehm_trackers_python() {
    let mut pose =
        SimccLandmarker::load_from(runtime(), &models().join(WHOLEBODY_FILES[1])).expect("dwpose");
    let (photo, fixture) = (Rgb8::from(&portrait()), fixture());
    // The box of the person EHM-Tracker kept: the one its crop is centred on.
    let kept = floats(&fixture["largest_person"]["centre"]);
    let person = fixture["boxes"]
        .as_array()
        .expect("boxes")
        .iter()
        .map(|b| {
            let b = floats(b);
            [b[0] as f32, b[1] as f32, b[2] as f32, b[3] as f32]
        })
        .find(|b| {
            let centre = DVec2::new(b[0] as f64 + b[2] as f64, b[1] as f64 + b[3] as f64) / 2.0;
            (centre - DVec2::new(kept[0], kept[1])).length() < 1e-3
        })
        .expect("the kept person's box is one of the boxes");
    for (case, corners) in [("largest_person", Some(person)), ("whole_photo", None)] {
        let expected = &fixture[case];
        let crop = pose.crop(&photo, corners);
        let (centre, scale) = (floats(&expected["centre"]), floats(&expected["scale"]));
        let crop_off = max_abs(
            &[crop.centre.x, crop.centre.y, crop.scale.x, crop.scale.y],
            &[centre[0], centre[1], scale[0], scale[1]],
        );
        let input = blocks(&pose.input(&photo, crop), 288, 384);
        let input_off = max_abs(&input, &floats(&expected["input_blocks"]));
        let found = pose.detect(&photo, corners).expect("runs");
        let want = points(&expected["points"]);
        let scores = floats(&expected["scores"]);
        let bin = crop.scale.x as f32 / 288.0 / 2.0;
        let moved: Vec<f32> = found
            .points
            .iter()
            .zip(&want)
            .map(|(a, b)| (*a - *b).abs().max_element() / bin)
            .collect();
        let same = moved.iter().filter(|&&m| m < 1e-3).count();
        let worst = moved.iter().copied().fold(0.0, f32::max);
        let found_scores: Vec<f64> = found.scores.iter().map(|&s| s as f64).collect();
        let score_off = max_abs(&found_scores, &scores);
        println!(
            "{case}: crop {crop_off:.1e} px, input blocks {input_off:.1e}, points in the same bin \
             {same}/{}, worst {worst:.2} bins, scores {score_off:.1e}",
            want.len()
        );
        assert!(crop_off < 1e-6, "{case}: crop {crop_off}");
        // The warped input is OpenCV's to the bit (one 8-bit level would move a block average
        // by up to 1.7e-2); what is left is the order of float sums.
        assert!(input_off < 1e-5, "{case}: input {input_off}");
        // So every point lands in the same bin (half an input pixel) as EHM-Tracker's.
        assert_eq!(same, want.len(), "{case}: worst {worst} bins");
        assert!(score_off < 1e-4, "{case}: scores {score_off}");
    }
}

#[test]
fn wholebody_keeps_the_largest_person_and_gives_the_fit_its_points() {
    let mut wholebody = Wholebody::load_dir(runtime(), &models()).expect("stand-in models");
    let source = portrait();
    let found = wholebody.detect(&source).expect("runs");
    let fixture = fixture();
    let expected = &fixture["largest_person"];
    let centre = floats(&expected["centre"]);
    assert!(
        (found.found.crop.centre - DVec2::new(centre[0], centre[1])).length() < 1e-3,
        "kept the person DWposeDetector keeps"
    );
    assert_eq!(
        found.people.len(),
        fixture["boxes"].as_array().expect("boxes").len()
    );
    // Its box (pixel edges) is the one the tracker crops around: centred where DWPose's crop is.
    let [l, t, r, b] = found.person().expect("a kept person");
    let middle = Vec2::new(l + r, t + b) / 2.0 - 0.5;
    assert!(
        (middle.as_dvec2() - DVec2::new(centre[0], centre[1])).length() < 1e-3,
        "{middle}"
    );

    // The body points under the fit's names, in our pixel-edge coordinates.
    let body = found.body();
    assert_eq!(body.len(), 17);
    for (i, k) in body.iter().enumerate() {
        assert_eq!(k.name, COCO_FROM_MEDIAPIPE[i].0);
        assert_eq!(k.pixel, found.found.points[i] + Vec2::splat(0.5));
    }
    // Hands: 21 points each from COCO-WholeBody's hand blocks, kept when seen.
    for hand in found.hands() {
        let first = match hand.side {
            guava::keypoints::Side::Left => 91,
            guava::keypoints::Side::Right => 112,
        };
        assert_eq!(hand.points[0], found.found.points[first] + Vec2::splat(0.5));
        assert_eq!(hand.points.len(), 21);
        assert!(hand.presence >= 0.5);
    }

    // In the keypoint pipeline the body and hand points are EHM-Tracker's, the person's presence
    // and mask still MediaPipe's.
    let mut landmarkers = Landmarkers::load(runtime())
        .expect("shipped models")
        .with_wholebody(runtime(), &models())
        .expect("stand-in models");
    let detections = landmarkers.detect(&source).expect("runs");
    let mediapipe = landmarkers.pose(&source).expect("runs");
    assert_eq!(detections.pose.keypoints, body);
    assert_eq!(detections.hands, found.hands());
    assert_eq!(detections.pose.presence, mediapipe.presence);
    assert_eq!(detections.pose.mask, mediapipe.mask);
}

#[test]
fn wholebody_folder_errors_name_the_files() {
    let dir = std::env::temp_dir().join(format!("guava-wholebody-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let err = Wholebody::load_dir(runtime(), &dir)
        .err()
        .expect("empty folder");
    let text = err.to_string();
    assert!(
        text.contains("yolox_l.onnx") && text.contains("dw-ll_ucoco_384.onnx"),
        "{text}"
    );
    // MediaPipe's pose model under DWPose's name: the wrong inputs and outputs, named.
    std::fs::copy(
        models().join(WHOLEBODY_FILES[0]),
        dir.join(WHOLEBODY_FILES[0]),
    )
    .expect("copy");
    std::fs::copy(
        data("assets/models/pose_landmark_full.onnx"),
        dir.join(WHOLEBODY_FILES[1]),
    )
    .expect("copy");
    let err = Wholebody::load_dir(runtime(), &dir)
        .err()
        .expect("wrong model");
    let text = err.to_string();
    assert!(
        text.contains("dw-ll_ucoco_384.onnx") && text.contains("DWPose"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The head and shoulders of a fitted view in the camera's frame (metres), by COCO name.
fn head_and_shoulders(body: &BodyModel, view: &SourceView) -> Vec<(String, Vec3)> {
    let mut posed = PosedBody::default();
    body.pose(&view.pose, &mut posed).expect("poses");
    COCO_FROM_MEDIAPIPE[..7]
        .iter()
        .map(|&(name, _)| {
            let l = body
                .landmarks
                .iter()
                .find(|l| l.name == name)
                .expect("a COCO landmark");
            let world: Vec3 = l
                .vertices
                .iter()
                .zip(&l.weights)
                .map(|(&v, &w)| w * posed.vertices[v as usize])
                .sum();
            (
                name.to_string(),
                view.camera.view_from_world.transform_point3(world),
            )
        })
        .collect()
}

/// What the fit makes of DWPose's layout, end to end: an oracle DWPose (tests/data/dwpose_oracle)
/// answers the same body points whatever it sees (MediaPipe's TFLite answer on the demo
/// portrait), so the pipeline must hand the fit those points, under COCO's names, seen where the
/// oracle is sure, and no hands (it is unsure of them); and the fit of what the pipeline hands it
/// must match the fit of those points given directly — a point given the wrong name or side
/// would turn the body, or mirror it to face away.
#[test]
fn the_fit_reads_dwposes_points_as_given() {
    let source = portrait();
    let oracle = &fixture()["oracle"];
    let mut models = Landmarkers::load(runtime())
        .expect("shipped models")
        .with_wholebody(runtime(), &data("tests/data/dwpose_oracle"))
        .expect("oracle models");
    let found = models.detect(&source).expect("runs");
    let seen: Vec<bool> = oracle["seen"]
        .as_array()
        .expect("seen")
        .iter()
        .map(|s| s.as_bool().expect("bool"))
        .collect();
    let given: Vec<Keypoint> = COCO_FROM_MEDIAPIPE
        .iter()
        .zip(points(&oracle["points"]))
        .zip(&seen)
        .map(|((&(name, _), pixel), &seen)| Keypoint {
            name,
            pixel,
            confidence: if seen { 1.0 } else { 0.0 },
        })
        .collect();
    // One SimCC bin is half an input pixel: 640 / 288 / 2 = 1.1 photo pixels.
    let bin = 640.0 / 288.0 / 2.0;
    for (k, g) in found.pose.keypoints.iter().zip(&given) {
        let off = (k.pixel - g.pixel).abs().max_element();
        assert!(
            k.name == g.name && off <= bin / 2.0 + 1e-3,
            "{}: {off} px",
            k.name
        );
        assert_eq!(k.confidence >= 0.5, g.confidence > 0.5, "{}", k.name);
    }
    assert!(found.hands.is_empty());

    let body = BodyModel::default_body().expect("default body");
    let mut direct = found.clone();
    direct.pose.keypoints = given;
    let (through, t) = fit_detections(&body, &found, &mut models.face, source.size).expect("fits");
    let (reference, r) =
        fit_detections(&body, &direct, &mut models.face, source.size).expect("fits");
    let (a, b) = (
        head_and_shoulders(&body, &reference),
        head_and_shoulders(&body, &through),
    );
    let worst = a
        .iter()
        .zip(&b)
        // Across the view: along it, 2D points leave the depth loose (as camera depth below).
        .map(|((_, p), (_, q))| (*p / p.z - *q / q.z).truncate().length() * p.z.abs())
        .fold(0.0, f32::max);
    let depth = (a[0].1.z / b[0].1.z - 1.0).abs();
    println!(
        "oracle DWPose through the pipeline vs its points given: {} / {} body keypoints at \
         {:.2} / {:.2} px RMS; head and shoulders {:.2} cm apart across the view at most, camera depth {:.2} % apart",
        t.keypoints_used,
        r.keypoints_used,
        t.rms_px,
        r.rms_px,
        worst * 100.0,
        depth * 100.0
    );
    assert_eq!(t.keypoints_used, r.keypoints_used);
    // The pipeline's points are the given ones to within half a bin (0.56 px, ~1 mm here); the
    // fit of these points (MediaPipe's shoulders on the suit's neck ring, 12–16 px RMS) is
    // loose enough that this moves it by 1.8 cm. Swapping the two shoulders moves it 15 cm.
    assert!(worst < 0.03, "{worst} m");
    assert!(depth < 0.01, "{depth}");
    // Facing the camera (GUAVA's looks along +z): the nose nearer than both ears, the subject's
    // left on the image's right.
    assert!(b[0].1.z < b[3].1.z.min(b[4].1.z), "{b:?}");
    assert!(b[1].1.x > b[2].1.x && b[5].1.x > b[6].1.x, "{b:?}");
}

/// With EHM-Tracker's models loaded, a fitted photo is framed around YOLOX's box of the person
/// kept, as EHM-Tracker's tracker crops (`crop_image_by_bbox` on `det_info['bbox']`), not around
/// MediaPipe's mask: on the square demo portrait (whose whole-photo square is the source the
/// stand-ins ran on above) the frame is exactly `Crop::around` that box.
#[test]
fn ehm_trackers_person_box_frames_the_photo() {
    use guava::pipeline::{Framing, SourcePhoto, Square};
    let mut landmarkers = Landmarkers::load(runtime())
        .and_then(|m| m.with_wholebody(runtime(), &models()))
        .expect("models");
    let boxed = Wholebody::load_dir(runtime(), &models())
        .expect("stand-ins")
        .detect(&portrait())
        .expect("runs")
        .person()
        .expect("a kept person");
    let read = SourcePhoto::read(
        &data("assets/demo_portrait.png"),
        Square::Fitted(Framing::AroundPerson),
        Some(&mut landmarkers),
        &mut |_| true,
    )
    .expect("reads");
    let crop = read.crop.expect("framed");
    println!("YOLOX box {boxed:?} → {crop:?}");
    assert_eq!(crop, guava::photo::Crop::around(boxed));
    // The framed square's detections carry the box the fit's square was framed around.
    assert!(read.detections.expect("detected").person.is_some());
}
