#!/usr/bin/env python3
"""Writes the ONNX Runtime smoke fixture: tests/data/tiny_mlp.onnx and tests/data/tiny_mlp.json.

The model is y = softplus(x · W + b) followed by a 2×2 average pool over a [1, 2, 4, 4] reshape,
so the test exercises MatMul, Add, Softplus, Reshape and AveragePool. The expected outputs are
computed with onnx's own reference evaluator (pure NumPy), independent of ONNX Runtime.

Run once (needs `pip install onnx numpy`; CI does not run this):
    python3 tools/make_onnx_fixture.py
"""
import json
import pathlib

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper
from onnx.reference import ReferenceEvaluator

OUT = pathlib.Path(__file__).resolve().parent.parent / "tests" / "data"


def main() -> None:
    rng = np.random.default_rng(20261123)
    w = rng.standard_normal((8, 32)).astype(np.float32)
    b = rng.standard_normal((32,)).astype(np.float32)
    x = rng.standard_normal((3, 8)).astype(np.float32)

    nodes = [
        helper.make_node("MatMul", ["x", "W"], ["xw"]),
        helper.make_node("Add", ["xw", "b"], ["h"]),
        helper.make_node("Softplus", ["h"], ["s"]),
        helper.make_node("Reshape", ["s", "shape"], ["img"]),
        helper.make_node("AveragePool", ["img"], ["y"], kernel_shape=[2, 2], strides=[2, 2]),
    ]
    graph = helper.make_graph(
        nodes,
        "tiny_mlp",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [3, 8])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [3, 2, 2, 2])],
        initializer=[
            numpy_helper.from_array(w, "W"),
            numpy_helper.from_array(b, "b"),
            numpy_helper.from_array(np.array([3, 2, 4, 4], dtype=np.int64), "shape"),
        ],
    )
    # Opset 17 / IR 8: loadable by every ONNX Runtime the project supports (1.31+).
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8)
    onnx.checker.check_model(model)
    (y,) = ReferenceEvaluator(model).run(None, {"x": x})

    OUT.mkdir(parents=True, exist_ok=True)
    onnx.save(model, OUT / "tiny_mlp.onnx")
    fixture = {
        "input_name": "x",
        "input_shape": list(x.shape),
        "input": x.ravel().tolist(),
        "output_shape": list(y.shape),
        "output": y.astype(np.float32).ravel().tolist(),
        "generated_by": "tools/make_onnx_fixture.py (onnx reference evaluator)",
    }
    (OUT / "tiny_mlp.json").write_text(json.dumps(fixture, indent=1) + "\n")
    print(f"wrote {OUT / 'tiny_mlp.onnx'} and tiny_mlp.json, output shape {y.shape}")


if __name__ == "__main__":
    main()
