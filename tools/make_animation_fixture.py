"""Parity fixture for avatar animation: the reference `Ubody_Gaussian.forward` (template Gaussians
by per-vertex skinning, UV Gaussians by their triangle frames) on the synthetic EHM of
tools/make_ehm_fixture.py, with random Gaussian assets, posed by that fixture's "random" and
"extreme" parameter sets.

The assets follow the decoders' conventions (notes/guava-pipeline.md sections 4-5): template
rotations normalised across vertices (F.normalize's dim=1 on [B,N,4]), not per quaternion;
colours raw, of which Ubody_Gaussian sigmoids the first three on construction. Four colour
channels instead of 32 keep the file small (the deformation passes colours through).

    tests/data/animation_parity.npz   assets (as Ubody_Gaussian holds them after construction),
                                      and per case xyz, rotation, scaling, opacity

Regenerate (needs PyTorch on CPU, numpy, opencv-python-headless, pyyaml, lightning, roma,
plyfile, omegaconf, colored, rich; not needed by CI):

    python tools/make_animation_fixture.py --guava ../shared/reference/GUAVA
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from convert_ehm import ehm_arrays, write_npz  # noqa: E402
from make_ehm_fixture import synthetic_ehm  # noqa: E402
from reference_env import import_guava  # noqa: E402

CASES = [1, 2]  # "random" and "extreme" of ehm_parity.npz
UV_GAUSSIANS = 2000
CHANNELS = 4


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--guava", required=True, help="GUAVA repository (the reference code)")
    data = Path(__file__).resolve().parent.parent / "tests" / "data"
    parser.add_argument("--out", default=str(data / "animation_parity.npz"))
    args = parser.parse_args()
    guava_root = import_guava(args.guava)
    import torch
    import torch.nn.functional as F
    from models.UbodyAvatar.ubody_gaussian import Ubody_Gaussian

    torch.set_float32_matmul_precision("highest")
    ehm, cases = synthetic_ehm(guava_root)
    committed = np.load(data / "ehm_synthetic.npz")
    for key, value in ehm_arrays(ehm).items():
        if not np.array_equal(committed[key], value):
            sys.exit(f"the rebuilt synthetic EHM differs from tests/data/ehm_synthetic.npz in {key}")

    g = torch.Generator().manual_seed(7)
    n = ehm.smplx.v_template.shape[0]
    faces = ehm.smplx.faces_tensor.shape[0]
    k = UV_GAUSSIANS

    def randn(*shape):
        return torch.randn(*shape, generator=g)

    bary = torch.rand(1, k, 3, generator=g) + 0.05
    vertex_assets = {
        "scales": torch.sigmoid(randn(1, n, 3)) * 0.05,
        "rotations": F.normalize(randn(1, n, 4)),  # across vertices, as the decoder does
        "opacities": torch.sigmoid(randn(1, n, 1)),
        "positions": ehm.v_template[None].clone(),
        "static_offsets": None,
        "colors": randn(1, n, CHANNELS),
    }
    uv_assets = {
        "scales": torch.exp(randn(1, k, 3) * 0.5 - 4.0),
        "rotations": F.normalize(randn(1, k, 4), dim=-1),
        "opacities": torch.sigmoid(randn(1, k, 1)),
        "local_pos": randn(1, k, 3) * 0.3,
        "binding_face": torch.randint(0, faces, (1, k, 1), generator=g),
        "face_bary": bary / bary.sum(-1, keepdim=True),
        "colors": randn(1, k, CHANNELS),
    }
    cfg = type("Cfg", (), {"sh_degree": 0, "opacity_threshold": 0.001})()
    avatar = Ubody_Gaussian(cfg, vertex_assets, uv_assets, pruning=False)
    avatar.init_ehm(ehm)

    def f32(t):
        return np.ascontiguousarray(t.detach().numpy(), dtype="<f4")

    fixture = {
        "template_rotations": f32(avatar._smplx_rotation[0]),
        "template_scales": f32(avatar._smplx_scaling[0]),
        "template_opacities": f32(avatar._smplx_opacity[0, :, 0]),
        "template_features": f32(avatar._smplx_features_color[0]),
        "uv_triangles": np.ascontiguousarray(avatar._uv_binding_face.numpy(), dtype="<i8"),
        "uv_barycentrics": f32(avatar._uv_face_bary),
        "uv_offsets": f32(avatar._uv_local_xyz[0]),
        "uv_rotations": f32(avatar._uv_rotation[0]),
        "uv_scales": f32(avatar._uv_scaling[0]),
        "uv_opacities": f32(avatar._uv_opacity[0, :, 0]),
        "uv_features": f32(avatar._uv_features_color[0]),
        "cases": np.array(CASES, dtype="<i8"),
    }
    outputs = {key: [] for key in ["xyz", "rotation", "scaling", "opacity"]}
    for c in CASES:
        _, body, flame = cases[c]

        def batch(d):
            return {key: torch.tensor(np.asarray(v, dtype=np.float32))[None] for key, v in d.items()}

        out = avatar({"smplx_coeffs": batch(body), "flame_coeffs": batch(flame)})
        for key in outputs:
            outputs[key].append(f32(out[key][0]))
        xyz = out["xyz"][0]
        print(f"case {c}: {xyz.shape[0]} Gaussians, |xyz| max {xyz.abs().max():.3f}, "
              f"finite {bool(torch.isfinite(xyz).all())}")
    for key, values in outputs.items():
        fixture[f"out_{key}"] = np.stack(values)
    write_npz(args.out, fixture)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
