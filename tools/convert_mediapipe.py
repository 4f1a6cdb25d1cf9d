#!/usr/bin/env python3
"""Converts MediaPipe's pose, face and hand landmark models to ONNX and ships the demo portrait,
once, offline.

Needs (not in CI; a throw-away venv of ~1.7 GB):
    pip install mediapipe==0.10.21 tensorflow-cpu tf2onnx onnxruntime==1.32.0 pillow
    pip download --no-deps scikit-image==0.25.2 -d target/skimage
    python tools/convert_mediapipe.py --skimage-wheel target/skimage/scikit_image-0.25.2-*.whl

Writes (tf2onnx's bytes differ from run to run, names in the graph, while the numbers do not:
keep the committed model files unless the conversion itself changes):
- assets/models/pose_landmark_full.onnx: MediaPipe `pose_landmark_full.tflite` (Apache-2.0, from
  the mediapipe 0.10.21 wheel) through tf2onnx, opset 17. Input [1,256,256,3] RGB in [0, 1];
  outputs 39×5 landmarks (x, y, z in input pixels, visibility and presence logits), the pose
  presence score, and 256² person-segmentation logits.
- assets/demo_portrait.png: scikit-image's `astronaut.png` (Eileen Collins, NASA; public domain).
- tests/data/pose_landmark_fixture.json and tests/data/demo_portrait_256.png: the model's input
  for the demo portrait (the centred square crop resized to 256² by Pillow, 8-bit) and what the
  TFLite interpreter outputs for it, so the Rust test checks our ONNX path against MediaPipe's own.
- assets/models/face_landmark.onnx: MediaPipe `face_landmark.tflite` (Apache-2.0, same wheel),
  opset 17. Input [1,192,192,3] RGB in [0, 1] (a face crop with margin, eyes level); outputs
  468×3 landmarks (x, y in input pixels, z relative depth) and a face-presence logit.
- tests/data/face_landmark_fixture.json and tests/data/demo_face_192.png: an axis-aligned face crop
  of the demo portrait (the box is fixed here, not our crop code) and TFLite's output for it.
- assets/models/hand_landmark_full.onnx: MediaPipe `hand_landmark_full.tflite` (Apache-2.0, same
  wheel), opset 17. Input [1,224,224,3] RGB in [0, 1] (a hand crop, fingers up); outputs 21×3
  landmarks in input pixels, a hand-presence score, handedness and 21×3 world landmarks.
- tests/data/hand_landmark_fixture.json and tests/data/demo_hand_224.png: a crop of the demo
  portrait where her right hand would be (the portrait shows no hand: the numbers check the
  conversion, the low presence what the model says of a crop without a hand) and TFLite's output.
- assets/models/iris_landmark.onnx: MediaPipe `iris_landmark.tflite` (Apache-2.0, same wheel),
  opset 17. Input [1,64,64,3] RGB in [0, 1] (a square around one eye, 2.3× the corner-to-corner
  extent, eye corners level; trained on the subject's right eye, so the left eye's crop is
  mirrored); outputs 71×3 eye-contour and brow points and 5×3 iris points (centre first), in
  input pixels.
- tests/data/iris_landmark_fixture.json, tests/data/demo_eye_right_64.png and
  demo_eye_left_64.png: both eyes of the demo portrait in fixed boxes (the left one mirrored) and
  TFLite's output for each.
- assets/models/pose_detection.onnx: MediaPipe `pose_detection.tflite` (Apache-2.0, same wheel),
  opset 17, after a pre-pass that stores each DENSIFY op's output (block-sparse weights) as a
  dense constant, which tf2onnx cannot read otherwise. Input [1,224,224,3] RGB in [-1, 1] (the
  photo letterboxed to 224²); outputs 2254×12 box and keypoint offsets per SSD anchor and 2254
  score logits.
- tests/data/pose_detection_fixture.json and tests/data/demo_portrait_224.png: the detector's
  input for the demo portrait and TFLite's outputs at its five best anchors; and, for the demo
  portrait and tests/data/camera.png (scikit-image's `camera.png`, CC0 by Lav Varshney, grey
  made RGB), the 33 body landmarks MediaPipe's own pose pipeline (`mediapipe.solutions.pose`,
  static images, the full model: detector, crop, landmarks) finds, in pixels.
- assets/models/palm_detection_full.onnx: MediaPipe `palm_detection_full.tflite` (Apache-2.0,
  same wheel), opset 17. Input [1,192,192,3] RGB in [0, 1] (the photo letterboxed to 192²);
  outputs 2016×18 box and seven-keypoint offsets per SSD anchor and 2016 score logits.
- tests/data/palm_detection_fixture.json: for tests/data/drawn_wave.png (the default body drawn
  by this project's `synthetic::shaded` in the demo motion's wave, 512²; the test
  `the_hand_is_found_on_a_drawn_body_where_its_joints_are` draws it again and checks that it is
  this picture), the detector's input at 192²
  (tests/data/drawn_wave_192.png), TFLite's outputs at its five best anchors, and the 21 points
  of each hand MediaPipe's own hand pipeline (`mediapipe.solutions.hands`, static images) finds.
- assets/models/face_detection_short_range.onnx: MediaPipe `face_detection_short_range.tflite`
  (Apache-2.0, same wheel), opset 17. Input [1,128,128,3] RGB in [-1, 1] (the photo letterboxed
  to 128²); outputs 896×16 box and six-keypoint offsets per SSD anchor and 896 score logits.
- tests/data/face_detection_fixture.json and tests/data/demo_portrait_128.png: the detector's
  input for the demo portrait and TFLite's outputs at its five best anchors.
- assets/models/selfie_segmentation.onnx: MediaPipe `selfie_segmentation.tflite` (Apache-2.0, same
  wheel), opset 17. Input [1,256,256,3] RGB in [0, 1] (the photo's square resized); output
  [1,256,256,1] person probability. Its last layer is MediaPipe's custom op
  `Convolution2DTransposeBias` (a 2×2, stride-2 transposed convolution with bias), which tf2onnx
  cannot read: the graph is cut before it, converted, and the op appended as ONNX's ConvTranspose
  with the model's own (fp16) kernel and bias, then the model's sigmoid. Checked against the
  truncated TFLite graph plus the same op in NumPy (the cut) and against MediaPipe's own
  `solutions.selfie_segmentation` on the demo portrait (the op's meaning: mask IoU).
Each converted model is checked against the TFLite interpreter on the real photo (not only random
input) before anything is written. `--models iris` (a comma-separated subset of pose, face,
hand, iris, detector, palm, facedet, selfie) converts only those; the pose model's run also
writes the demo portrait.
"""
import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import zipfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SKIMAGE_ASTRONAUT_SHA256 = "88431cd9653ccd539741b555fb0a46b61558b301d4110412b5bc28b5e3ea6cb5"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--skimage-wheel", required=True)
    ap.add_argument("--models", default="pose,face,hand,iris,detector,palm,facedet,selfie")
    args = ap.parse_args()
    wanted = set(args.models.split(","))

    import mediapipe
    import onnxruntime as ort
    import tensorflow as tf
    from PIL import Image

    if mediapipe.__version__ != "0.10.21":
        sys.exit(f"need mediapipe 0.10.21 (its wheel ships the models), found {mediapipe.__version__}")
    modules = os.path.join(os.path.dirname(mediapipe.__file__), "modules")
    tflite = os.path.join(modules, "pose_landmark/pose_landmark_full.tflite")

    with zipfile.ZipFile(args.skimage_wheel) as whl:
        portrait = whl.read("skimage/data/astronaut.png")
    digest = hashlib.sha256(portrait).hexdigest()
    if digest != SKIMAGE_ASTRONAUT_SHA256:
        sys.exit(f"astronaut.png has sha256 {digest}, expected {SKIMAGE_ASTRONAUT_SHA256}")

    models = os.path.join(ROOT, "assets/models")
    os.makedirs(models, exist_ok=True)
    image = Image.open(__import__("io").BytesIO(portrait)).convert("RGB")
    if "pose" in wanted:
        pose(tf, ort, image, portrait, tflite, models)
    if "face" in wanted:
        face(tf, ort, image, os.path.join(modules, "face_landmark/face_landmark.tflite"), models)
    if "hand" in wanted:
        hand(tf, ort, image, os.path.join(modules, "hand_landmark/hand_landmark_full.tflite"), models)
    if "iris" in wanted:
        iris(tf, ort, image, os.path.join(modules, "iris_landmark/iris_landmark.tflite"), models)
    if "detector" in wanted:
        with zipfile.ZipFile(args.skimage_wheel) as whl:
            camera = Image.open(__import__("io").BytesIO(whl.read("skimage/data/camera.png")))
        camera = camera.convert("RGB")
        camera.save(os.path.join(ROOT, "tests/data/camera.png"))
        detector(tf, ort, image, camera, os.path.join(modules, "pose_detection/pose_detection.tflite"), models)
    if "palm" in wanted:
        palm(tf, ort, os.path.join(modules, "palm_detection/palm_detection_full.tflite"), models)
    if "selfie" in wanted:
        selfie(tf, ort, image, os.path.join(modules, "selfie_segmentation/selfie_segmentation.tflite"), models)
    if "facedet" in wanted:
        face_detector(tf, ort, image, os.path.join(modules, "face_detection/face_detection_short_range.tflite"), models)


def selfie(tf, ort, portrait, tflite, models):
    import mediapipe
    import onnx
    import tf2onnx
    from onnx import TensorProto, helper, numpy_helper
    from PIL import Image
    from tensorflow.lite.tools import flatbuffer_utils
    model = flatbuffer_utils.read_model(tflite)
    graph = model.subgraphs[0]
    names = [t.name.decode() for t in graph.tensors]
    custom = [i for i, op in enumerate(graph.operators)
              if model.operatorCodes[op.opcodeIndex].customCode == b"Convolution2DTransposeBias"]
    if len(custom) != 1:
        sys.exit(f"selfie_segmentation: expected one Convolution2DTransposeBias, found {len(custom)}")
    op = graph.operators[custom[0]]
    features = names[op.inputs[0]]

    def constant(dequantized):
        # The kernel and bias are fp16 constants read through DEQUANTIZE ops.
        producer = next(o for o in graph.operators if names[o.outputs[0]] == dequantized)
        t = graph.tensors[producer.inputs[0]]
        dtype = {1: np.float16, 0: np.float32}[t.type]
        data = bytes(model.buffers[t.buffer].data)
        return np.frombuffer(data, dtype=dtype).reshape(t.shape).astype(np.float32)

    kernel = constant(names[op.inputs[1]])  # OHWI: [1, 2, 2, 16]
    bias = constant(names[op.inputs[2]])
    # Cut: everything up to the features the custom op reads.
    graph.operators = [o for o in graph.operators[:custom[0]]
                       if model.operatorCodes[o.opcodeIndex].builtinCode != 6 or
                       names[o.outputs[0]] not in (names[op.inputs[1]], names[op.inputs[2]])]
    graph.outputs = np.array([names.index(features)], dtype=np.int32)
    with tempfile.TemporaryDirectory() as tmp:
        cut = os.path.join(tmp, "cut.tflite")
        flatbuffer_utils.write_model(model, cut)
        proto, _ = tf2onnx.convert.from_tflite(cut, opset=17)
        x = np.asarray(portrait.resize((256, 256), Image.BILINEAR), np.float32)[None] / 255.0
        cut_features = run_tflite(tf, cut, x)
    onnx_graph = proto.graph
    out = onnx_graph.output[0].name
    onnx_graph.initializer.append(
        numpy_helper.from_array(np.transpose(kernel, (3, 0, 1, 2)).copy(), "segment_W"))
    onnx_graph.initializer.append(numpy_helper.from_array(bias.reshape(1), "segment_B"))
    onnx_graph.node.extend([
        helper.make_node("Transpose", [out], ["segment_nchw"], perm=[0, 3, 1, 2]),
        helper.make_node("ConvTranspose", ["segment_nchw", "segment_W", "segment_B"], ["segment"],
                         strides=[2, 2], kernel_shape=[2, 2]),
        helper.make_node("Sigmoid", ["segment"], ["probability"]),
        helper.make_node("Transpose", ["probability"], ["segmentation"], perm=[0, 2, 3, 1]),
    ])
    del onnx_graph.output[:]
    onnx_graph.output.append(
        helper.make_tensor_value_info("segmentation", TensorProto.FLOAT, [1, 256, 256, 1]))
    onnx.checker.check_model(proto)
    onnx_bytes = proto.SerializeToString()
    # The cut: the truncated TFLite graph and the custom op in NumPy against the ONNX model.
    f = list(cut_features.values())[0][0]
    up = np.zeros((256, 256), np.float32)
    for dy in range(2):
        for dx in range(2):
            up[dy::2, dx::2] = f @ kernel[0, dy, dx, :] + bias[0]
    expected = 1.0 / (1.0 + np.exp(-np.clip(up, -80, 80)))
    session = ort.InferenceSession(onnx_bytes)
    got = session.run(None, {session.get_inputs()[0].name: x})[0][0, :, :, 0]
    worst = float(np.abs(got - expected).max())
    if worst > 1e-4:
        sys.exit(f"selfie_segmentation: ONNX differs from TFLite by {worst}")
    # The op's meaning: MediaPipe's own solution on the demo portrait.
    with mediapipe.solutions.selfie_segmentation.SelfieSegmentation(model_selection=0) as s:
        theirs = s.process(np.asarray(portrait)).segmentation_mask
    ours = np.asarray(Image.fromarray(got).resize(portrait.size, Image.BILINEAR))
    a, b = theirs > 0.5, ours > 0.5
    iou = float((a & b).sum() / max((a | b).sum(), 1))
    if iou < 0.97:
        sys.exit(f"selfie_segmentation: mask IoU {iou} against MediaPipe's solution")
    print(f"selfie_segmentation: {worst:.1e} from TFLite at the cut, IoU {iou:.4f} with MediaPipe")
    open(os.path.join(models, "selfie_segmentation.onnx"), "wb").write(onnx_bytes)


def face_detector(tf, ort, portrait, tflite, models):
    from PIL import Image
    small = portrait.resize((128, 128), Image.BILINEAR)
    x = np.asarray(small, np.float32)[None] / 127.5 - 1.0
    onnx_bytes = to_onnx(tflite)
    found = best_anchors(tf, ort.InferenceSession(onnx_bytes), tflite, x, 896, "face detector")
    small.save(os.path.join(ROOT, "tests/data/demo_portrait_128.png"))
    fixture = {"model": "mediapipe 0.10.21 modules/face_detection/face_detection_short_range.tflite",
               **found}
    path = os.path.join(models, "face_detection_short_range.onnx")
    open(path, "wb").write(onnx_bytes)
    json.dump(fixture, open(os.path.join(ROOT, "tests/data/face_detection_fixture.json"), "w"))
    print(f"wrote {path} ({len(onnx_bytes) / 1e6:.1f} MB) and the face detector fixture")


def palm(tf, ort, tflite, models):
    import mediapipe
    from PIL import Image
    drawn = Image.open(os.path.join(ROOT, "tests/data/drawn_wave.png")).convert("RGB")
    small = drawn.resize((192, 192), Image.BILINEAR)
    x = np.asarray(small, np.float32)[None] / 255.0
    onnx_bytes = to_onnx(tflite)
    found_anchors = best_anchors(tf, ort.InferenceSession(onnx_bytes), tflite, x, 2016, "palm")
    with mediapipe.solutions.hands.Hands(static_image_mode=True, max_num_hands=2) as hands:
        found = hands.process(np.asarray(drawn))
    hands_found = [[[round(l.x * drawn.width, 2), round(l.y * drawn.height, 2)] for l in h.landmark]
                   for h in (found.multi_hand_landmarks or [])]
    print(f"palm: MediaPipe's hand pipeline finds {len(hands_found)} hands on the drawing")
    small.save(os.path.join(ROOT, "tests/data/drawn_wave_192.png"))
    fixture = {
        "model": "mediapipe 0.10.21 modules/palm_detection/palm_detection_full.tflite",
        **found_anchors,
        "pipeline": "mediapipe.solutions.hands.Hands(static_image_mode=True, max_num_hands=2)",
        "hands": hands_found,
    }
    path = os.path.join(models, "palm_detection_full.onnx")
    open(path, "wb").write(onnx_bytes)
    json.dump(fixture, open(os.path.join(ROOT, "tests/data/palm_detection_fixture.json"), "w"))
    print(f"wrote {path} ({len(onnx_bytes) / 1e6:.1f} MB) and the palm fixture")


def densified(tf, tflite, out):
    """`tflite` with each DENSIFY op's output stored as a constant and the op dropped."""
    from tensorflow.lite.python import schema_py_generated as schema
    from tensorflow.lite.tools import flatbuffer_utils
    model = flatbuffer_utils.read_model(tflite)
    graph = model.subgraphs[0]

    def is_densify(op):
        c = model.operatorCodes[op.opcodeIndex]
        return max(c.builtinCode, c.deprecatedBuiltinCode) == schema.BuiltinOperator.DENSIFY

    ops = [op for op in graph.operators if is_densify(op)]
    # Without the default (XNNPACK) delegate, which would swallow the DENSIFY ops and leave their
    # outputs zero.
    interpreter = tf.lite.Interpreter(
        tflite, experimental_preserve_all_tensors=True,
        experimental_op_resolver_type=tf.lite.experimental.OpResolverType.BUILTIN_WITHOUT_DEFAULT_DELEGATES)
    interpreter.allocate_tensors()
    d = interpreter.get_input_details()[0]
    interpreter.set_tensor(d["index"], np.zeros(d["shape"], np.float32))
    interpreter.invoke()
    for op in ops:
        value = interpreter.get_tensor(op.outputs[0])
        if not np.abs(value).max() > 0:
            sys.exit(f"{tflite}: a DENSIFY output is all zero; the pre-pass went wrong")
        buffer = schema.BufferT()
        buffer.data = np.frombuffer(value.tobytes(), np.uint8)
        model.buffers.append(buffer)
        graph.tensors[op.outputs[0]].buffer = len(model.buffers) - 1
        # The sparse input is read no more: without data and sparsity converters skip it.
        graph.tensors[op.inputs[0]].buffer = 0
        graph.tensors[op.inputs[0]].sparsity = None
    graph.operators = [op for op in graph.operators if not is_densify(op)]
    flatbuffer_utils.write_model(model, out)
    print(f"detector: {len(ops)} DENSIFY ops stored as constants")


def detector(tf, ort, portrait, camera, tflite, models):
    import mediapipe
    from PIL import Image
    with tempfile.TemporaryDirectory() as tmp:
        dense = os.path.join(tmp, "dense.tflite")
        densified(tf, tflite, dense)
        onnx_bytes = to_onnx(dense)
    session = ort.InferenceSession(onnx_bytes)
    fixture = {"model": "mediapipe 0.10.21 modules/pose_detection/pose_detection.tflite"}
    for name, photo in [("demo_portrait", portrait), ("camera", camera)]:
        small = photo.resize((224, 224), Image.BILINEAR)
        x = np.asarray(small, np.float32)[None] / 127.5 - 1.0
        # Against the original (sparse) model: the densified weights must be its own.
        found_anchors = best_anchors(tf, session, tflite, x, 2254, f"detector ({name})")
        with mediapipe.solutions.pose.Pose(static_image_mode=True, model_complexity=1) as pose:
            found = pose.process(np.asarray(photo))
        if found.pose_landmarks is None:
            sys.exit(f"MediaPipe's pose pipeline finds no person on {name}")
        entry = {
            "pipeline": "mediapipe.solutions.pose.Pose(static_image_mode=True, model_complexity=1)",
            "landmarks": [[round(l.x * photo.width, 2), round(l.y * photo.height, 2),
                           round(l.visibility, 3)] for l in found.pose_landmarks.landmark],
        }
        if name == "demo_portrait":
            small.save(os.path.join(ROOT, "tests/data/demo_portrait_224.png"))
            entry.update(found_anchors)
        fixture[name] = entry
    path = os.path.join(models, "pose_detection.onnx")
    open(path, "wb").write(onnx_bytes)
    json.dump(fixture, open(os.path.join(ROOT, "tests/data/pose_detection_fixture.json"), "w"))
    print(f"wrote {path} ({len(onnx_bytes) / 1e6:.1f} MB) and the detector fixture")


def pose(tf, ort, image, portrait, tflite, models):
    from PIL import Image
    onnx_path = os.path.join(models, "pose_landmark_full.onnx")
    onnx_bytes = to_onnx(tflite)

    # The model's input for the portrait: centred square (it is square), 256², [0, 1].
    side = min(image.size)
    left, top = (image.width - side) // 2, (image.height - side) // 2
    small = image.crop((left, top, left + side, top + side)).resize((256, 256), Image.BILINEAR)
    x = np.asarray(small, np.float32)[None] / 255.0

    outputs = run_tflite(tf, tflite, x)
    landmarks = next(v for v in outputs.values() if v.shape == (1, 195)).reshape(39, 5)
    presence = next(v for v in outputs.values() if v.shape == (1, 1))

    session = ort.InferenceSession(onnx_bytes)
    got = dict(zip([o.name for o in session.get_outputs()], session.run(None, {session.get_inputs()[0].name: x})))
    lm_onnx = got["Identity"].reshape(39, 5)
    worst = np.abs(lm_onnx[:, :2] - landmarks[:, :2]).max()
    if worst > 0.01:
        sys.exit(f"ONNX and TFLite landmarks differ by {worst} px")
    if abs(got["Identity_1"].item() - presence.item()) > 1e-3 or presence.item() < 0.5:
        sys.exit(f"presence {got['Identity_1'].item()} vs TFLite {presence.item()}")
    print(f"ONNX vs TFLite on the portrait: landmarks within {worst:.2e} px, presence {presence.item():.3f}")

    open(onnx_path, "wb").write(onnx_bytes)
    open(os.path.join(ROOT, "assets/demo_portrait.png"), "wb").write(portrait)
    small.save(os.path.join(ROOT, "tests/data/demo_portrait_256.png"))
    fixture = {
        "source": "TFLite interpreter (tensorflow " + tf.__version__ + ") on tests/data/demo_portrait_256.png / 255",
        "model": "mediapipe 0.10.21 modules/pose_landmark/pose_landmark_full.tflite",
        "landmarks": [[round(float(v), 4) for v in row] for row in landmarks],
        "presence": round(float(presence.item()), 5),
    }
    json.dump(fixture, open(os.path.join(ROOT, "tests/data/pose_landmark_fixture.json"), "w"), indent=1)
    print(f"wrote {onnx_path} ({len(onnx_bytes) / 1e6:.1f} MB), assets/demo_portrait.png, the fixture")


# The demo portrait's eyes (subject's right, then left): squares 2.3× the corner-to-corner
# extent around the corners' midpoint (MediaPipe's iris crop), from face-mesh points 33/133 and
# 362/263 of the face fixture, rounded; the boxes are fixed here, not our crop code.
EYE_BOXES = {"right": (180, 79, 226, 125), "left": (224, 81, 271, 128)}


def iris(tf, ort, image, tflite, models):
    from PIL import Image
    onnx_bytes = to_onnx(tflite)
    session = ort.InferenceSession(onnx_bytes)
    fixture = {
        "source": "TFLite interpreter on tests/data/demo_eye_{right,left}_64.png / 255 (the demo "
                  "portrait's boxes resized by Pillow, bilinear; the left eye's mirrored)",
        "model": "mediapipe 0.10.21 modules/iris_landmark/iris_landmark.tflite",
    }
    for side, box in EYE_BOXES.items():
        crop = image.crop(box).resize((64, 64), Image.BILINEAR)
        if side == "left":
            crop = crop.transpose(Image.FLIP_LEFT_RIGHT)
        x = np.asarray(crop, np.float32)[None] / 255.0
        outputs = run_tflite(tf, tflite, x)
        got = dict(zip([o.name for o in session.get_outputs()],
                       session.run(None, {session.get_inputs()[0].name: x})))
        contour = next(v for v in outputs.values() if v.size == 213)
        iris_points = next(v for v in outputs.values() if v.size == 15)
        worst = max(np.abs(next(v for v in got.values() if v.size == n) - ref).max()
                    for n, ref in [(213, contour), (15, iris_points)])
        if worst > 0.01:
            sys.exit(f"iris ({side} eye): ONNX and TFLite differ by {worst} px")
        print(f"iris ({side} eye): ONNX vs TFLite within {worst:.2e} px, centre {iris_points.ravel()[:2]}")
        crop.save(os.path.join(ROOT, f"tests/data/demo_eye_{side}_64.png"))
        fixture[side] = {
            "box": list(box),
            "contour": [round(float(v), 3) for v in contour.ravel()],
            "iris": [round(float(v), 3) for v in iris_points.ravel()],
        }
    path = os.path.join(models, "iris_landmark.onnx")
    open(path, "wb").write(onnx_bytes)
    json.dump(fixture, open(os.path.join(ROOT, "tests/data/iris_landmark_fixture.json"), "w"))
    print(f"wrote {path} ({len(onnx_bytes) / 1e6:.1f} MB) and the iris fixture")


# Her right hand's side of the demo portrait (it is out of frame): the suit's cuff and glove area.
HAND_BOX = (40, 300, 200, 460)


def hand(tf, ort, image, tflite, models):
    from PIL import Image
    crop = image.crop(HAND_BOX).resize((224, 224), Image.BILINEAR)
    x = np.asarray(crop, np.float32)[None] / 255.0
    outputs = run_tflite(tf, tflite, x)
    onnx_bytes = to_onnx(tflite)
    session = ort.InferenceSession(onnx_bytes)
    got = dict(zip([o.name for o in session.get_outputs()], session.run(None, {session.get_inputs()[0].name: x})))
    worst = max(np.abs(got[k] - outputs[k]).max() for k in outputs)
    if worst > 0.01:
        sys.exit(f"hand: ONNX and TFLite differ by {worst}")
    print(f"hand: ONNX vs TFLite within {worst:.2e}, presence {outputs['Identity_1'].item():.3f}")
    path = os.path.join(models, "hand_landmark_full.onnx")
    open(path, "wb").write(onnx_bytes)
    crop.save(os.path.join(ROOT, "tests/data/demo_hand_224.png"))
    fixture = {
        "source": "TFLite interpreter on tests/data/demo_hand_224.png / 255 (the demo portrait's "
                  f"box {list(HAND_BOX)} resized by Pillow, bilinear)",
        "model": "mediapipe 0.10.21 modules/hand_landmark/hand_landmark_full.tflite",
        "landmarks": [round(float(v), 3) for v in outputs["Identity"].ravel()],
        "presence": round(float(outputs["Identity_1"].item()), 5),
        "handedness": round(float(outputs["Identity_2"].item()), 5),
    }
    json.dump(fixture, open(os.path.join(ROOT, "tests/data/hand_landmark_fixture.json"), "w"))
    print(f"wrote {path} ({len(onnx_bytes) / 1e6:.1f} MB) and the hand fixture")


# The demo portrait's face, by eye: a square around it with MediaPipe's ~1.5× margin.
FACE_BOX = (140, 36, 316, 212)


def face(tf, ort, image, tflite, models):
    from PIL import Image
    crop = image.crop(FACE_BOX).resize((192, 192), Image.BILINEAR)
    x = np.asarray(crop, np.float32)[None] / 255.0
    outputs = run_tflite(tf, tflite, x)
    landmarks = next(v for v in outputs.values() if v.size == 1404).reshape(468, 3)
    flag = next(v for v in outputs.values() if v.size == 1).item()
    onnx_bytes = to_onnx(tflite)
    session = ort.InferenceSession(onnx_bytes)
    got = session.run(None, {session.get_inputs()[0].name: x})
    lm_onnx = next(v for v in got if v.size == 1404).reshape(468, 3)
    worst = np.abs(lm_onnx[:, :2] - landmarks[:, :2]).max()
    flag_onnx = next(v for v in got if v.size == 1).item()
    if worst > 0.01 or abs(flag_onnx - flag) > 1e-3 or flag < 0:
        sys.exit(f"face: ONNX and TFLite landmarks differ by {worst} px, flags {flag_onnx} vs {flag}")
    print(f"face: ONNX vs TFLite within {worst:.2e} px, face logit {flag:.2f}")
    path = os.path.join(models, "face_landmark.onnx")
    open(path, "wb").write(onnx_bytes)
    crop.save(os.path.join(ROOT, "tests/data/demo_face_192.png"))
    fixture = {
        "source": "TFLite interpreter on tests/data/demo_face_192.png / 255 (the demo portrait's "
                  f"box {list(FACE_BOX)} resized by Pillow, bilinear)",
        "model": "mediapipe 0.10.21 modules/face_landmark/face_landmark.tflite",
        "landmarks": [[round(float(v), 3) for v in row] for row in landmarks],
        "face_logit": round(flag, 4),
        "box": list(FACE_BOX),
    }
    json.dump(fixture, open(os.path.join(ROOT, "tests/data/face_landmark_fixture.json"), "w"))
    print(f"wrote {path} ({len(onnx_bytes) / 1e6:.1f} MB) and the face fixture")


def best_anchors(tf, session, tflite, x, anchors, what):
    """An SSD detector's outputs on `x` from the TFLite interpreter and from our ONNX `session`,
    checked to agree (box values run to ~200 input pixels); its five best anchors' values as
    fixture entries."""
    outputs = run_tflite(tf, tflite, x)
    got = dict(zip([o.name for o in session.get_outputs()],
                   session.run(None, {session.get_inputs()[0].name: x})))
    worst = max(np.abs(got[k] - outputs[k]).max() for k in outputs)
    if worst > 0.01:
        sys.exit(f"{what}: ONNX and TFLite differ by {worst}")
    scores = next(v for v in outputs.values() if v.size == anchors).ravel()
    boxes = next(v for v in outputs.values() if v.size > anchors).reshape(anchors, -1)
    best = np.argsort(-scores)[:5]
    print(f"{what}: ONNX vs TFLite within {worst:.2e}; best score "
          f"{1 / (1 + np.exp(-scores[best[0]])):.3f} at anchor {best[0]}")
    return {
        "anchors": [int(i) for i in best],
        "boxes": [[round(float(v), 3) for v in boxes[i]] for i in best],
        "scores": [round(float(scores[i]), 4) for i in best],
    }


def to_onnx(tflite):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "model.onnx")
        subprocess.run([sys.executable, "-m", "tf2onnx.convert", "--tflite", tflite, "--output", out,
                        "--opset", "17"], check=True, capture_output=True)
        return open(out, "rb").read()


def run_tflite(tf, tflite, x):
    interpreter = tf.lite.Interpreter(tflite)
    interpreter.allocate_tensors()
    interpreter.set_tensor(interpreter.get_input_details()[0]["index"], x)
    interpreter.invoke()
    return {d["name"]: interpreter.get_tensor(d["index"]) for d in interpreter.get_output_details()}


if __name__ == "__main__":
    main()
