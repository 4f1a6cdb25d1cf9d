"""Convert SMPL-X + FLAME (registration-only files) into guava-rs's EHM model file.

GUAVA mode poses EHM: SMPL-X with its head replaced by FLAME. The model files cannot ship, so a user
who has them runs this once:

    python tools/convert_ehm.py --guava PATH/TO/GUAVA --out ehm_model.npz

with `SMPLX_NEUTRAL_2020.npz` (and `SMPLX_to_J14.pkl`) in `GUAVA/assets/SMPLX/` and FLAME's
`generic_model.pkl` in `GUAVA/assets/FLAME/FLAME2020/`, exactly where GUAVA itself expects them
(`--assets DIR` points elsewhere: a folder with `SMPLX/` and `FLAME/` laid out the same way). The
reference constructor itself builds the model (teeth for both SMPL-X and FLAME, shape/expression
slicing, pose-corrective layout), so the file holds exactly the buffers the reference forward uses.
Needs the environment of GUAVA's own ONNX export: PyTorch (CPU is enough), numpy, opencv-python-
headless, pyyaml, and chumpy for the official FLAME pickle.

Output: an uncompressed-or-deflated .npz of little-endian arrays (format "guava-rs ehm 1"), read by
`src/body/ehm/file.rs`. Row-major, float32 unless noted:
  smplx_v_template [V,3]      smplx_faces [F,3] i32       smplx_faces_uv [F,3] i32
  smplx_texcoords [T,2] (v flipped as in the reference: v = 1 - v_obj)
  smplx_shapedirs [V,3,S+E]   smplx_posedirs [54*9, V*3]  smplx_j_regressor [55,V]
  smplx_parents [55] i32      smplx_weights [V,55]
  smplx_to_flame [Vf] i32     left_hand [778] i32         right_hand [778] i32
  left_hand_center [3]        right_hand_center [3]
  flame_v_template [Vf,3]     flame_shapedirs [Vf,3,S+E]  flame_posedirs [4*9, Vf*3]
  flame_j_regressor [5,Vf]    flame_parents [5] i32       flame_weights [Vf,5]
  flame_l_eyelid [Vf,3]       flame_r_eyelid [Vf,3]
  uv_texel_face [U,U] i32     uv_texel_bary [U,U,3]   (the reference's own texel -> face map and
                              barycentrics, rasterized by OpenCV at start-up, U = 512 as GUAVA
                              uses; GUAVA mode samples with it so its texels are the reference's)
  n_shape, n_exp [1] i32      format: 0-d unicode string
"""

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reference_env import import_guava  # noqa: E402

FORMAT = "guava-rs ehm 1"
N_SHAPE, N_EXP = 300, 50  # EHM.__init__ defaults, used by GUAVA's inference


def build_reference_ehm(assets_dir, uv_size=512):
    """The reference EHM exactly as GUAVA's inference constructs it (add_teeth=True)."""
    from models.modules.ehm.EHM import EHM

    assets_dir = Path(assets_dir)
    return EHM(str(assets_dir / "FLAME"), str(assets_dir / "SMPLX"), add_teeth=True,
               uv_size=uv_size)


def ehm_arrays(ehm):
    smplx, flame = ehm.smplx, ehm.flame

    def f32(t):
        return np.ascontiguousarray(t.detach().cpu().numpy(), dtype="<f4")

    def i32(a):
        a = a.detach().cpu().numpy() if hasattr(a, "detach") else np.asarray(a)
        return np.ascontiguousarray(a, dtype="<i4")

    return {
        "format": np.array(FORMAT),
        "n_shape": np.array([smplx.n_shape], dtype="<i4"),
        "n_exp": np.array([smplx.n_exp], dtype="<i4"),
        "smplx_v_template": f32(smplx.v_template),
        "smplx_faces": i32(smplx.faces_tensor),
        "smplx_faces_uv": i32(smplx.faces_uv_idx),
        "smplx_texcoords": f32(smplx.texcoords),
        "smplx_shapedirs": f32(smplx.shapedirs),
        "smplx_posedirs": f32(smplx.posedirs),
        "smplx_j_regressor": f32(smplx.J_regressor),
        "smplx_parents": i32(smplx.parents),
        "smplx_weights": f32(smplx.lbs_weights),
        "smplx_to_flame": i32(smplx.smplx2flame_ind),
        "left_hand": i32(smplx.smplx2mano_ind["left_hand"]),
        "right_hand": i32(smplx.smplx2mano_ind["right_hand"]),
        "left_hand_center": f32(smplx.left_hand_center),
        "right_hand_center": f32(smplx.right_hand_center),
        "flame_v_template": f32(flame.v_template),
        "flame_shapedirs": f32(flame.shapedirs),
        "flame_posedirs": f32(flame.posedirs),
        "flame_j_regressor": f32(flame.J_regressor),
        "flame_parents": i32(flame.parents),
        "flame_weights": f32(flame.lbs_weights),
        "flame_l_eyelid": f32(flame.l_eyelid[0]),
        "flame_r_eyelid": f32(flame.r_eyelid[0]),
        "uv_texel_face": i32(smplx.uvmap_f_idx),
        "uv_texel_bary": f32(smplx.uvmap_f_bary),
    }


def write_npz(path, arrays, mode=0o644):
    """Deflated npz written next to the target and renamed, so a failed run leaves no half file."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".npz.tmp")
    os.close(fd)
    try:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays)
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--guava", required=True, help="GUAVA repository (the reference code)")
    parser.add_argument("--assets", help="folder with SMPLX/ and FLAME/ (default: GUAVA/assets)")
    parser.add_argument("--out", required=True, help="output .npz")
    args = parser.parse_args()
    root = import_guava(args.guava)
    assets = Path(args.assets) if args.assets else root / "assets"
    for required in ["SMPLX/SMPLX_NEUTRAL_2020.npz", "FLAME/FLAME2020/generic_model.pkl"]:
        if not (assets / required).is_file():
            sys.exit(f"{assets / required}: missing (registration-only model file; see the docstring)")
    write_npz(args.out, ehm_arrays(build_reference_ehm(assets)))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
