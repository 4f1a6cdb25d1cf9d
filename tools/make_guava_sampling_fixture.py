"""Parity fixture for GUAVA mode's geometry between the networks: the reference
`Ubody_Gaussian_inferer.sample_prj_feature` (feature maps sampled at the projected posed
vertices, border padding) and `convert_pixel_feature_to_uv` (inverse texture mapping with face
visibility, zero padding), run on the synthetic EHM of tools/make_ehm_fixture.py posed by its
"random" case, random feature maps and a GUAVA-style camera.

The reference's texel map (OpenCV-filled, `uvmap_f_idx`/`uvmap_f_bary`) and a given set of
visible faces are inputs here, so the Rust side is tested on the same geometry; how the texel
map and the visible set are made is where our pipeline departs from the reference (see
src/guava_mode/reconstruct.rs), and is not part of this check.

    tests/data/guava_sampling_parity.npz

Regenerate (needs PyTorch on CPU and the packages tools/make_animation_fixture.py lists):

    python tools/make_guava_sampling_fixture.py --guava ../shared/reference/GUAVA
"""

import argparse
import sys
import types
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from convert_ehm import write_npz  # noqa: E402
from make_ehm_fixture import synthetic_ehm  # noqa: E402
from reference_env import import_guava  # noqa: E402

UV_SIZE = 64
FEATURE_SIDE = 64
VERTEX_CHANNELS = 3
PIXEL_CHANNELS = 5
INVTANFOV = 24.0
# Turned 180° about x (camera y down, looking at the body's front from +z), 22 m away as the
# tracker's cameras are, centred 0.2 m above the pelvis.
W2C = np.array([[1, 0, 0, 0], [0, -1, 0, 0.2], [0, 0, -1, 22], [0, 0, 0, 1]], dtype=np.float32)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--guava", required=True, help="GUAVA repository (the reference code)")
    data = Path(__file__).resolve().parent.parent / "tests" / "data"
    parser.add_argument("--out", default=str(data / "guava_sampling_parity.npz"))
    args = parser.parse_args()
    guava_root = import_guava(args.guava)
    import torch
    from models.UbodyAvatar.ubody_gaussian import Ubody_Gaussian_inferer as Inferer

    torch.set_float32_matmul_precision("highest")
    ehm, cases = synthetic_ehm(guava_root, uv_size=UV_SIZE)
    _, body, flame = cases[1]

    def batch(d):
        return {k: torch.tensor(np.asarray(v, dtype=np.float32))[None] for k, v in d.items()}

    vertices = ehm(batch(body), batch(flame))["vertices"]
    g = torch.Generator().manual_seed(3)
    vertex_maps = torch.randn(1, VERTEX_CHANNELS, FEATURE_SIDE, FEATURE_SIDE, generator=g)
    pixel_maps = torch.randn(1, PIXEL_CHANNELS, FEATURE_SIDE, FEATURE_SIDE, generator=g)
    faces = ehm.smplx.faces_tensor.shape[0]
    visible = torch.nonzero(torch.rand(faces, generator=g) < 0.6)[:, 0].to(torch.int32)
    w2c = torch.tensor(W2C)[None]

    inferer = types.SimpleNamespace(
        cfg=types.SimpleNamespace(invtanfov=INVTANFOV, uvmap_size=UV_SIZE), smplx=ehm.smplx)
    sampled, _ = Inferer.sample_prj_feature(inferer, vertices, vertex_maps, w2c)
    uv = Inferer.convert_pixel_feature_to_uv(inferer, pixel_maps, vertices, w2c,
                                             visble_faces=visible[None])

    def f32(t):
        return np.ascontiguousarray(t.detach().numpy(), dtype="<f4")

    write_npz(args.out, {
        "vertices": f32(vertices[0]),
        "w2c": W2C,
        "invtanfov": np.array([INVTANFOV], dtype="<f4"),
        "vertex_maps": f32(vertex_maps[0]),
        "pixel_maps": f32(pixel_maps[0]),
        "visible_faces": np.ascontiguousarray(visible.numpy(), dtype="<i8"),
        "uvmap_f_idx": np.ascontiguousarray(ehm.smplx.uvmap_f_idx.numpy(), dtype="<i8"),
        "uvmap_f_bary": f32(ehm.smplx.uvmap_f_bary),
        "out_sampled": f32(sampled[0]),
        "out_uv_features": f32(uv[0]),
    })
    inside = (uv[0].abs().sum(0) > 0).sum().item()
    print(f"{vertices.shape[1]} vertices, {visible.numel()} of {faces} faces visible, "
          f"{int(ehm.smplx.uvmap_mask.sum())} texels, {inside} of them sampled; wrote {args.out}")


if __name__ == "__main__":
    main()
