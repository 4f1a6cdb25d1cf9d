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
so that the crop, the normalisation and the decoding all change the answer. It then runs
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
POINTS = 133
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


def yolox(rng, path):
    nodes, inits, heads = [], [], []
    for s in (8, 16, 32):
        w = rng.normal(0.0, 1.0 / 255.0, (85, 3, 1, 1))
        b = np.zeros(85)
        b[2:4] = np.log(6.0)  # boxes about six cells wide and high
        b[4] = -2.3  # objectness: a few boxes pass
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
        const("sigma2", [2.0 * 6.0**2]),
        const("score_scale", [1.2]),
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
    inits += [
        numpy_helper.from_array(np.array([2], dtype=np.int64), "s2"),
        numpy_helper.from_array(np.array([3], dtype=np.int64), "s3"),
        numpy_helper.from_array(np.array([2], dtype=np.int64), "ax2"),
    ]
    nodes.insert(6, helper.make_node("Slice", ["unit", "s2", "s3", "ax2"], ["u2"]))
    nodes.insert(7, helper.make_node("Mul", ["u2", "score_scale"], ["score"]))
    graph = helper.make_graph(
        nodes,
        "dwpose_stand_in",
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
    with open(os.path.join(OUT, "fixture.json"), "w") as f:
        json.dump(fixture, f)
    print(f"{len(boxes)} person boxes; wrote {OUT}")


if __name__ == "__main__":
    main()
