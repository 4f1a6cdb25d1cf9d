"""Parity fixtures for the Rust EHM: a synthetic SMPL-X + FLAME, converted, and reference outputs.

The real SMPL-X and FLAME files are registration-only, so this writes stand-ins with the real array
names and shapes: the real rest geometry GUAVA ships as OBJ files (SMPL-X `smplx_uv.obj`, FLAME
`head_template.obj`), the real SMPL-X kinematic tree and FLAME's, and random content elsewhere
(shape/expression directions on a spread of components, pose correctives for every joint on a subset
of vertices, 4 random skin influences per vertex, joint regressors over random vertices). Values
are multiples of 1/16 times a power of two, so they are exact in float32 and the zero-heavy arrays
deflate to a small file. GUAVA's own small index files (SMPL-X <-> FLAME ids, hands, eyelids,
masks, UVs) are used as they are.

It then runs the reference code on CPU in float32 (`EHM.__init__` with add_teeth=True, then
`EHM.forward`) on three parameter sets: rest, random, and extreme (rotations of pi, 2 pi, 10 rad and
gimbal-aligned axes; coefficients at +-10; head and hand scales far from 1), and writes

    tests/data/ehm_synthetic.npz   the converted model (tools/convert_ehm.py format)
    tests/data/ehm_parity.npz      inputs and outputs per case (stacked on axis 0)

Regenerate (needs PyTorch on CPU, numpy, opencv-python-headless, pyyaml; not needed by CI):

    python tools/make_ehm_fixture.py --guava ../shared/reference/GUAVA
"""

import argparse
import pickle
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from convert_ehm import build_reference_ehm, ehm_arrays, write_npz  # noqa: E402
from reference_env import import_guava, read_obj  # noqa: E402

SEED = 20251123
# SMPL-X's kinematic tree (kintree_table[0] of SMPLX_NEUTRAL_2020.npz).
SMPLX_PARENTS = [
    -1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 15, 15, 15,
    20, 25, 26, 20, 28, 29, 20, 31, 32, 20, 34, 35, 20, 37, 38,
    21, 40, 41, 21, 43, 44, 21, 46, 47, 21, 49, 50, 21, 52, 53,
]  # fmt: skip
FLAME_PARENTS = [-1, 0, 1, 1, 1]  # global, neck, jaw, left eye, right eye
SHAPE_COMPONENTS = [0, 1, 2, 37, 150, 299]  # nonzero shape directions (of 300)
EXPRESSION_COMPONENTS = [300, 301, 325, 349]  # nonzero expression directions (300..349)
TRANSFORM_STRIDE = 5  # per-vertex transforms are saved for every 5th vertex
# The reference texel map is stored at the reduced GUAVA test models' UV size, not GUAVA's 512
# (tests/data/guava_onnx; a 512² map would add megabytes).
UV_SIZE = 32


def quantized(rng, shape, scale):
    return rng.integers(-16, 17, size=shape) / 16.0 * scale


def directions(rng, vertex_count, components, scale):
    out = np.zeros((vertex_count, 3, 400))
    out[:, :, components] = quantized(rng, (vertex_count, 3, len(components)), scale)
    return out


def pose_correctives(rng, vertex_count, joint_count, stride, scale):
    out = np.zeros((vertex_count, 3, joint_count * 9))
    out[::stride] = quantized(rng, out[::stride].shape, scale)
    return out


def skin_weights(rng, vertex_count, joint_count, influences):
    weights = np.zeros((vertex_count, joint_count))
    for v in range(vertex_count):
        joints = rng.choice(joint_count, size=influences, replace=False)
        raw = rng.integers(1, 17, size=influences).astype(np.float64)
        weights[v, joints] = raw / raw.sum()
    return weights


def joint_regressor(rng, joint_count, vertex_count, per_joint):
    out = np.zeros((joint_count, vertex_count))
    for j in range(joint_count):
        out[j, rng.choice(vertex_count, size=per_joint, replace=False)] = 1.0 / per_joint
    return out


def write_synthetic_assets(guava_root, dest, rng):
    """GUAVA's assets folder with synthetic stand-ins for the registration-only files."""
    shutil.copytree(guava_root / "assets" / "SMPLX", dest / "SMPLX")
    shutil.copytree(guava_root / "assets" / "FLAME", dest / "FLAME")

    v = read_obj(dest / "SMPLX" / "smplx_uv.obj")[0]
    vc = len(v)
    np.savez(
        dest / "SMPLX" / "SMPLX_NEUTRAL_2020.npz",
        f=np.load(dest / "SMPLX" / "smplx_faces.npy").astype(np.int64),
        v_template=v,
        shapedirs=directions(rng, vc, SHAPE_COMPONENTS + EXPRESSION_COMPONENTS, 2.0**-6),
        posedirs=pose_correctives(rng, vc, 54, 50, 2.0**-5),
        J_regressor=joint_regressor(rng, 55, vc, 6),
        kintree_table=np.array([SMPLX_PARENTS, list(range(55))], dtype=np.int64),
        weights=skin_weights(rng, vc, 55, 4),
        lmk_faces_idx=rng.integers(0, 20908, size=51),
        lmk_bary_coords=np.full((51, 3), 1.0 / 3.0),
        dynamic_lmk_faces_idx=rng.integers(0, 20908, size=(79, 17)),
        dynamic_lmk_bary_coords=np.full((79, 17, 3), 1.0 / 3.0),
    )
    with open(dest / "SMPLX" / "SMPLX_to_J14.pkl", "wb") as f:
        pickle.dump(joint_regressor(rng, 14, vc, 4), f, protocol=2)

    fv, _, faces, _ = read_obj(dest / "FLAME" / "head_template.obj")
    fc = len(fv)
    (dest / "FLAME" / "FLAME2020").mkdir()
    with open(dest / "FLAME" / "FLAME2020" / "generic_model.pkl", "wb") as f:
        pickle.dump(
            {
                "f": faces,
                "v_template": fv,
                "shapedirs": directions(rng, fc, SHAPE_COMPONENTS + EXPRESSION_COMPONENTS, 2.0**-7),
                "posedirs": pose_correctives(rng, fc, 4, 10, 2.0**-6),
                "J_regressor": joint_regressor(rng, 5, fc, 6),
                "kintree_table": np.array([FLAME_PARENTS, list(range(5))], dtype=np.int64),
                "weights": skin_weights(rng, fc, 5, 3),
            },
            f,
            protocol=2,
        )


def parameter_cases(rng):
    """(name, body dict, flame dict) as numpy float32, in the tracker's layout (notes §2.1)."""

    def case(rot, coeff, offset, scale_spread):
        return {
            "shape": rng.standard_normal(300) * coeff,
            "exp": rng.standard_normal(50) * coeff,
            "global_pose": rng.standard_normal((1, 3)) * rot,
            "body_pose": rng.standard_normal((21, 3)) * rot,
            "left_hand_pose": rng.standard_normal((15, 3)) * rot,
            "right_hand_pose": rng.standard_normal((15, 3)) * rot,
            "joints_offset": rng.standard_normal((55, 3)) * offset,
            "head_scale": 1.0 + rng.standard_normal(3) * scale_spread,
            "hand_scale": 1.0 + rng.standard_normal(3) * scale_spread,
        }, {
            "shape_params": rng.standard_normal(300) * coeff,
            "expression_params": rng.standard_normal(50) * coeff,
            "pose_params": rng.standard_normal(3) * rot,
            "jaw_params": rng.standard_normal(3) * rot,
            "eye_pose_params": rng.standard_normal(6) * rot,
            "eyelid_params": rng.standard_normal(2) * coeff,
        }

    rest_body, rest_flame = case(0.0, 0.0, 0.0, 0.0)
    random_body, random_flame = case(0.3, 1.0, 0.01, 0.1)
    extreme_body, extreme_flame = case(3.0, 10.0, 0.05, 0.0)
    # Exact pi, 2 pi and 10 rad about coordinate and diagonal axes; gimbal-aligned neighbours.
    specials = np.array(
        [[np.pi, 0, 0], [0, 2 * np.pi, 0], [0, 0, 10.0], [np.pi / 2, 0, 0], [0, np.pi / 2, 0],
         [1e-9, 0, 0], [-np.pi, -np.pi, -np.pi]]
    )  # fmt: skip
    extreme_body["body_pose"][: len(specials)] = specials
    extreme_body["global_pose"][0] = [0, np.pi, 0]
    extreme_flame["jaw_params"] = np.array([np.pi, 0, 0])
    extreme_body["shape"] = np.sign(extreme_body["shape"]) * 10.0
    extreme_body["head_scale"] = np.array([2.0, 0.5, 1.5])
    extreme_body["hand_scale"] = np.array([0.2, 3.0, 1.0])
    return [
        ("rest", rest_body, rest_flame),
        ("random", random_body, random_flame),
        ("extreme", extreme_body, extreme_flame),
    ]


def synthetic_ehm(guava_root, uv_size=UV_SIZE):
    """The synthetic reference EHM and the parameter cases, from the same draws in the same order
    as main() (the other fixture scripts pose the same model)."""
    rng = np.random.default_rng(SEED)
    with tempfile.TemporaryDirectory() as tmp:
        write_synthetic_assets(guava_root, Path(tmp), rng)
        ehm = build_reference_ehm(Path(tmp), uv_size=uv_size)
    return ehm, parameter_cases(rng)


def reference_forward(ehm, body, flame):
    import torch

    def batch(d):
        return {k: torch.tensor(np.asarray(v, dtype=np.float32))[None] for k, v in d.items()}

    return ehm(batch(body), batch(flame))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--guava", required=True, help="GUAVA repository (the reference code)")
    parser.add_argument("--out-dir", default=str(Path(__file__).resolve().parent.parent / "tests" / "data"))
    args = parser.parse_args()
    guava_root = import_guava(args.guava)
    import torch

    torch.set_float32_matmul_precision("highest")
    out_dir = Path(args.out_dir)
    ehm, cases = synthetic_ehm(guava_root)
    write_npz(out_dir / "ehm_synthetic.npz", ehm_arrays(ehm), mode=0o644)

    fixture = {"case_names": np.array([name for name, _, _ in cases])}
    outputs = [reference_forward(ehm, body, flame) for _, body, flame in cases]
    for key in cases[0][1]:
        fixture[f"body_{key}"] = np.stack([np.asarray(b[key], np.float32) for _, b, _ in cases])
    for key in cases[0][2]:
        fixture[f"flame_{key}"] = np.stack([np.asarray(f[key], np.float32) for _, _, f in cases])
    for key, stride in [("vertices", 1), ("joints", 1), ("joints_transform", 1),
                        ("joint_transform_mat", 1), ("ver_transform_mat", TRANSFORM_STRIDE)]:  # fmt: skip
        fixture[f"out_{key}"] = np.stack([o[key][0, ::stride].numpy() for o in outputs])
    fixture["out_ver_transform_stride"] = np.array([TRANSFORM_STRIDE], dtype=np.int32)
    write_npz(out_dir / "ehm_parity.npz", fixture, mode=0o644)
    for name, o in zip(fixture["case_names"], outputs):
        v = o["vertices"][0]
        print(f"{name}: {v.shape[0]} vertices, |v| max {v.abs().max():.3f}, finite {bool(torch.isfinite(v).all())}")
    print(f"wrote {out_dir / 'ehm_synthetic.npz'} and {out_dir / 'ehm_parity.npz'}")


if __name__ == "__main__":
    main()
