"""Import the authors' GUAVA code (Apache-2.0) for conversion and parity fixtures.

The reference imports pytorch3d, which has no installable distribution here. The few pieces the
body-model path touches get faithful stand-ins (notes/guava-pipeline.md section 7):
- `pytorch3d.io.load_obj`: only `faces.textures_idx` and `aux.verts_uvs` are read (FLAME masks).
- `pytorch3d.structures.Meshes(...).laplacian_packed()`: a training regulariser stored as an unused
  non-persistent buffer; the stand-in returns a 1x1 zero instead of a dense 10595^2 matrix.

Needs PyTorch (CPU), numpy, opencv-python-headless and pyyaml. Nothing here is imported by the Rust
build or CI.
"""

import sys
import types
from pathlib import Path

import numpy as np


def read_obj(path):
    """Vertices [V,3] f64, texture coordinates [T,2] f64, and per triangle its vertex and
    texture-coordinate ids [F,3] (0-based; -1 where a corner has none)."""
    verts, uvs, faces_v, faces_t = [], [], [], []
    for line in Path(path).read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            verts.append([float(x) for x in parts[1:4]])
        elif parts[0] == "vt":
            uvs.append([float(x) for x in parts[1:3]])
        elif parts[0] == "f":
            corners = [p.split("/") for p in parts[1:4]]
            faces_v.append([int(c[0]) - 1 for c in corners])
            faces_t.append([int(c[1]) - 1 if len(c) > 1 and c[1] else -1 for c in corners])
    return (np.array(verts), np.array(uvs), np.array(faces_v, dtype=np.int64),
            np.array(faces_t, dtype=np.int64))


def _load_obj(path, load_textures=True):
    import torch

    verts, uvs, faces_v, faces_t = read_obj(path)
    faces = types.SimpleNamespace(
        verts_idx=torch.from_numpy(faces_v), textures_idx=torch.from_numpy(faces_t)
    )
    aux = types.SimpleNamespace(verts_uvs=torch.tensor(uvs, dtype=torch.float32))
    return torch.tensor(verts, dtype=torch.float32), faces, aux


class _Meshes:
    def __init__(self, verts, faces):
        self.verts, self.faces = verts, faces

    def laplacian_packed(self):
        import torch

        return torch.zeros(1, 1).to_sparse()


def install_pytorch3d_stand_ins():
    root = types.ModuleType("pytorch3d")
    io = types.ModuleType("pytorch3d.io")
    io.load_obj = _load_obj
    structures = types.ModuleType("pytorch3d.structures")
    structures.Meshes = _Meshes
    root.io, root.structures = io, structures
    sys.modules.update(
        {"pytorch3d": root, "pytorch3d.io": io, "pytorch3d.structures": structures}
    )


def import_guava(guava_root):
    """Puts the GUAVA repository on sys.path (its modules import `utils` and `models` from there)."""
    guava_root = Path(guava_root).resolve()
    if not (guava_root / "models" / "modules" / "ehm" / "EHM.py").is_file():
        sys.exit(f"{guava_root}: not a GUAVA checkout (models/modules/ehm/EHM.py missing)")
    install_pytorch3d_stand_ins()
    sys.path.insert(0, str(guava_root))
    import torch

    torch.set_grad_enabled(False)
    np.set_printoptions(precision=4)
    return guava_root
