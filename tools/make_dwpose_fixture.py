#!/usr/bin/env python3
"""Fixtures for the EHM-Tracker keypoint adapter (`src/keypoints/wholebody.rs`), made once, offline.

EHM-Tracker finds the person with YOLOX-L (`yolox_l.onnx`) and the 133 COCO-WholeBody points with
DWPose (`dw-ll_ucoco_384.onnx`, RTMPose with SimCC outputs). Those weights are not in any package
registry, so this script writes two small stand-ins with exactly their inputs and outputs:
- tests/data/dwpose/yolox_l.onnx: input `images` [1,3,640,640] (RGB 0–255, letterboxed, grey
  114 padding), output [1,8400,85] (per cell of the stride-8/16/32 grids: x, y offsets in cells,
  log w, log h, then objectness and 80 class scores after sigmoid), computed from the input's
  averages over each cell;
- tests/data/dwpose/dw-ll_ucoco_384.onnx: input `input` [1,3,384,288] (RGB normalised by
  ImageNet's mean and std), outputs `simcc_x` [1,133,576] and `simcc_y` [1,133,768] (per point a
  Gaussian bump of height `score` at a place that depends on the input's 96×96 block averages),
so that the crop, the normalisation and the decoding all change the answer; and an oracle pair
in tests/data/dwpose_oracle/ (YOLOX finding nobody, DWPose answering MediaPipe's body points on
the demo portrait whatever it sees) for checking what the fit makes of DWPose's points. It then runs
EHM-Tracker's own pre- and post-processing (`onnxdet.py`, `onnxpose.py` from
../shared/reference/EHM-Tracker, imported by path) on the demo portrait and writes what they give:
- tests/data/dwpose/fixture.json: the person boxes, and for the largest person (as
  `DWposeDetector` picks it) and for the whole photo (what EHM-Tracker does when YOLOX finds
  nobody) the crop's centre and scale, the 96×96 block averages of the model's input and the 133
  points with their scores (EHM-Tracker's pixel coordinates: pixel centres at integers).

Needs (not in CI) EHM-Tracker's pinned OpenCV and NumPy (OpenCV 5's warpAffine interpolates in
float and differs by up to 4 levels on 3 % of the crop's pixels):
    pip install numpy==1.26.4 onnx==1.16.2 onnxruntime opencv-python-headless==4.11.0.86
    python tools/make_dwpose_fixture.py
"""

import importlib.util
import json
import os

import cv2
import numpy as np
import onnx
import onnxruntime as ort
from onnx import TensorProto, helper, numpy_helper

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "tests", "data", "dwpose")
DWPOSE = os.path.join(ROOT, "..", "shared", "reference", "EHM-Tracker", "src", "modules", "dwpose")
ORACLE = os.path.join(ROOT, "tests", "data", "dwpose_oracle")
POINTS = 133
# MediaPipe's pose landmarks in COCO's body order (nose, eyes, ears, shoulders … ankles).
COCO_FROM_MEDIAPIPE = [0, 2, 5, 7, 8, 11, 12, 13, 14, 15, 16, 23, 24, 25, 26, 27, 28]
BLOCK = 96


def module(name):
    spec = importlib.util.spec_from_file_location(name, os.path.join(DWPOSE, name + ".py"))
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    return m


def const(name, array):
    return numpy_helper.from_array(np.asarray(array, dtype=np.float32), name)


def save(graph, path):
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)


def yolox(rng, path, objectness=-2.3):
    nodes, inits, heads = [], [], []
    for s in (8, 16, 32):
        w = rng.normal(0.0, 1.0 / 255.0, (85, 3, 1, 1))
        b = np.zeros(85)
        b[2:4] = np.log(6.0)  # boxes about six cells wide and high
        b[4] = objectness  # the default lets a few boxes pass
        b[5] = 1.0  # class 0, a person
        b[6:] = -2.0
        w[4:6] *= 4.0  # objectness and person follow the colours strongly
        inits += [const(f"w{s}", w), const(f"b{s}", b)]
        nodes += [
            helper.make_node("AveragePool", ["images"], [f"p{s}"], kernel_shape=[s, s], strides=[s, s]),
            helper.make_node("Conv", [f"p{s}", f"w{s}", f"b{s}"], [f"c{s}"]),
            helper.make_node("Reshape", [f"c{s}", "shape85"], [f"r{s}"]),
        ]
        heads.append(f"r{s}")
    inits.append(numpy_helper.from_array(np.array([1, 85, -1], dtype=np.int64), "shape85"))
    nodes += [
        helper.make_node("Concat", heads, ["cat"], axis=2),
        helper.make_node("Transpose", ["cat"], ["rows"], perm=[0, 2, 1]),
        helper.make_node("Slice", ["rows", "s0", "s4", "ax2"], ["box"]),
        helper.make_node("Slice", ["rows", "s4", "s85", "ax2"], ["logits"]),
        helper.make_node("Sigmoid", ["logits"], ["scores"]),
        helper.make_node("Concat", ["box", "scores"], ["output"], axis=2),
    ]
    for name, v in (("s0", 0), ("s4", 4), ("s85", 85), ("ax2", 2)):
        inits.append(numpy_helper.from_array(np.array([v], dtype=np.int64), name))
    graph = helper.make_graph(
        nodes,
        "yolox_stand_in",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, 640, 640])],
        [helper.make_tensor_value_info("output", TensorProto.FLOAT, [1, 8400, 85])],
        inits,
    )
    save(graph, path)


def dwpose(rng, path):
    """Per point a place and a score from the input's 96×96 block averages."""
    features = 3 * (384 // BLOCK) * (288 // BLOCK)
    w = rng.normal(0.0, 0.6, (features, POINTS * 3))
    b = np.zeros(POINTS * 3)
    nodes = [
        helper.make_node("AveragePool", ["input"], ["pooled"], kernel_shape=[BLOCK, BLOCK], strides=[BLOCK, BLOCK]),
        helper.make_node("Flatten", ["pooled"], ["flat"]),
        helper.make_node("MatMul", ["flat", "w"], ["mm"]),
        helper.make_node("Add", ["mm", "b"], ["lin"]),
        helper.make_node("Reshape", ["lin", "shape3"], ["per_point"]),
        helper.make_node("Sigmoid", ["per_point"], ["unit"]),
    ]
    inits = [
        const("w", w),
        const("b", b),
        numpy_helper.from_array(np.array([1, POINTS, 3], dtype=np.int64), "shape3"),
    ]
    simcc(nodes, inits, "dwpose_stand_in", path)


def oracle(bins, scores, path):
    """Answers the same points whatever it sees: x and y bins and scores per point."""
    unit = np.stack([bins[:, 0] / 575.0, bins[:, 1] / 767.0, np.asarray(scores) / 1.2], axis=1)
    nodes = [helper.make_node("Identity", ["answer"], ["unit"])]
    simcc(nodes, [const("answer", unit.reshape(1, POINTS, 3))], "dwpose_oracle", path)


def simcc(nodes, inits, name, path):
    """DWPose's outputs from `unit` [1,133,3] (x and y as fractions of the bins, score / 1.2):
    per point a Gaussian bump of that height at that place along each axis."""
    nodes = list(nodes) + [
        helper.make_node("Slice", ["unit", "s2", "s3", "ax2"], ["u2"]),
        helper.make_node("Mul", ["u2", "score_scale"], ["score"]),
    ]
    inits = list(inits) + [
        const("sigma2", [2.0 * 6.0**2]),
        const("score_scale", [1.2]),
        numpy_helper.from_array(np.array([2], dtype=np.int64), "s2"),
        numpy_helper.from_array(np.array([3], dtype=np.int64), "s3"),
        numpy_helper.from_array(np.array([2], dtype=np.int64), "ax2"),
    ]
    for axis, bins, out in ((0, 576, "simcc_x"), (1, 768, "simcc_y")):
        inits += [
            numpy_helper.from_array(np.array([axis], dtype=np.int64), f"a{axis}"),
            numpy_helper.from_array(np.array([axis + 1], dtype=np.int64), f"a{axis}e"),
            const(f"bins{axis}", np.arange(bins, dtype=np.float32).reshape(1, 1, bins)),
            const(f"len{axis}", [bins - 1.0]),
        ]
        nodes += [
            helper.make_node("Slice", ["unit", f"a{axis}", f"a{axis}e", "ax2"], [f"u{axis}"]),
            helper.make_node("Mul", [f"u{axis}", f"len{axis}"], [f"at{axis}"]),
            helper.make_node("Sub", [f"bins{axis}", f"at{axis}"], [f"d{axis}"]),
            helper.make_node("Mul", [f"d{axis}", f"d{axis}"], [f"dd{axis}"]),
            helper.make_node("Div", [f"dd{axis}", "sigma2"], [f"q{axis}"]),
            helper.make_node("Neg", [f"q{axis}"], [f"nq{axis}"]),
            helper.make_node("Exp", [f"nq{axis}"], [f"bump{axis}"]),
            helper.make_node("Mul", [f"bump{axis}", "score"], [out]),
        ]
    graph = helper.make_graph(
        nodes,
        name,
        [helper.make_tensor_value_info("input", TensorProto.FLOAT, [1, 3, 384, 288])],
        [
            helper.make_tensor_value_info("simcc_x", TensorProto.FLOAT, [1, POINTS, 576]),
            helper.make_tensor_value_info("simcc_y", TensorProto.FLOAT, [1, POINTS, 768]),
        ],
        inits,
    )
    save(graph, path)


def blocks(crop):
    """The 96×96 block averages of a model input (HWC, normalised), channel-major like the model's."""
    h, w, _ = crop.shape
    b = crop.reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK, 3).mean(axis=(1, 3))
    return b.transpose(2, 0, 1).reshape(-1).tolist()


def person(onnxpose, session, image, boxes):
    h, w = session.get_inputs()[0].shape[2:]
    crops, centres, scales = onnxpose.preprocess(image, boxes, (w, h))
    outputs = onnxpose.inference(session, crops)
    points, scores = onnxpose.postprocess(outputs, (w, h), centres, scales)
    return crops, centres, scales, points, scores


def main():
    os.makedirs(OUT, exist_ok=True)
    rng = np.random.default_rng(7)
    det_path, pose_path = os.path.join(OUT, "yolox_l.onnx"), os.path.join(OUT, "dw-ll_ucoco_384.onnx")
    yolox(rng, det_path)
    dwpose(rng, pose_path)
    onnxdet, onnxpose = module("onnxdet"), module("onnxpose")
    image = cv2.cvtColor(cv2.imread(os.path.join(ROOT, "assets", "demo_portrait.png")), cv2.COLOR_BGR2RGB)
    det = ort.InferenceSession(det_path, providers=["CPUExecutionProvider"])
    pose = ort.InferenceSession(pose_path, providers=["CPUExecutionProvider"])
    boxes = onnxdet.inference_detector(det, image)
    fixture = {"image": "assets/demo_portrait.png", "boxes": np.asarray(boxes).tolist()}
    cases = {}
    if len(boxes):
        crops, centres, scales, points, scores = person(onnxpose, pose, image, boxes)
        # DWposeDetector keeps the person whose points span the largest box.
        extent = points.max(axis=1) - points.min(axis=1)
        k = int(np.argmax(extent[:, 0] * extent[:, 1]))
        cases["largest_person"] = (crops[k], centres[k], scales[k], points[k], scores[k])
    crops, centres, scales, points, scores = person(onnxpose, pose, image, [])
    cases["whole_photo"] = (crops[0], centres[0], scales[0], points[0], scores[0])
    for name, (crop, centre, scale, pts, sc) in cases.items():
        fixture[name] = {
            "centre": np.asarray(centre).tolist(),
            "scale": np.asarray(scale).tolist(),
            "input_blocks": blocks(crop),
            "points": np.asarray(pts).tolist(),
            "scores": np.asarray(sc).tolist(),
        }
    fixture["oracle"] = make_oracle(rng_oracle=np.random.default_rng(8))
    with open(os.path.join(OUT, "fixture.json"), "w") as f:
        json.dump(fixture, f)
    print(f"{len(boxes)} person boxes; wrote {OUT} and {ORACLE}")


def make_oracle(rng_oracle):
    """The oracle pair: YOLOX finding nobody (so DWPose sees the whole photo) and a DWPose that
    answers MediaPipe's COCO points on the demo portrait (its TFLite pose landmarks on the whole
    photo, tests/data/pose_landmark_fixture.json) with score 0.9 where MediaPipe is confident,
    every other point (feet, face, hands) unsure at the crop's centre. Returns the points it
    answers in pixel-edge coordinates of the 512² photo and whether each is seen."""
    os.makedirs(ORACLE, exist_ok=True)
    yolox(rng_oracle, os.path.join(ORACLE, "yolox_l.onnx"), objectness=-30.0)
    with open(os.path.join(ROOT, "tests", "data", "pose_landmark_fixture.json")) as f:
        landmarks = np.asarray(json.load(f)["landmarks"], dtype=np.float64)
    sigmoid = lambda v: 1.0 / (1.0 + np.exp(-v))
    coco = landmarks[COCO_FROM_MEDIAPIPE]
    edge = coco[:, :2] * (512.0 / 256.0)
    seen = sigmoid(coco[:, 3]) * sigmoid(coco[:, 4]) >= 0.5
    # The whole photo's crop as onnxpose.py makes it: box (0, 0, 512, 512) × 1.25 to 3:4.
    centre, scale = np.array([256.0, 256.0]), np.array([640.0, 640.0 / 0.75])
    input_size = np.array([288.0, 384.0])
    bins = np.tile(input_size, (POINTS, 1))  # unsure points: the crop's centre, in bins
    bins[: len(coco)] = ((edge - 0.5) - (centre - scale / 2)) / scale * input_size * 2.0
    scores = np.full(POINTS, 0.05)
    scores[: len(coco)] = np.where(seen, 0.9, 0.05)
    oracle(bins, scores, os.path.join(ORACLE, "dw-ll_ucoco_384.onnx"))
    return {"points": edge.tolist(), "seen": seen.tolist()}


if __name__ == "__main__":
    main()
