"""Import the authors' GUAVA code (Apache-2.0) for conversion and parity fixtures.

The reference imports pytorch3d, which has no installable distribution here. The few pieces the
body-model path touches get faithful stand-ins (notes/guava-pipeline.md section 7):
- `pytorch3d.io.load_obj`: only `faces.textures_idx` and `aux.verts_uvs` are read (FLAME masks).
- `pytorch3d.structures.Meshes(...).laplacian_packed()`: a training regulariser stored as an unused
  non-persistent buffer; the stand-in returns a 1x1 zero instead of a dense 10595^2 matrix.
- `pytorch3d.renderer.implicit.harmonic_embedding.HarmonicEmbedding`: the formula itself.
- the renderer classes `utils/graphics_utils.py` imports, `open3d` and the CUDA splatter
  `diff_gaussian_rasterization_32`: names only (importing works; instantiating one says it is a
  stand-in), since the paths we run (EHM, the decoders, `Ubody_Gaussian.forward`) never use them.

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


class _Unavailable:
    """Names the reference imports from pytorch3d's renderer (base classes, settings) but never
    instantiates on the paths we run; using one says so instead of failing obscurely."""

    def __init__(self, *args, **kwargs):
        raise NotImplementedError(f"{type(self).__name__} is a pytorch3d stand-in")


def harmonic_embedding(n_harmonic_functions):
    """pytorch3d HarmonicEmbedding(n) with its defaults (omega_0 = 1, logspace, append_input):
    x -> [sin(x_d 2^i) ‖ cos(x_d 2^i) ‖ x], d-major then frequency (notes section 7)."""
    import torch

    def embed(x):
        freqs = 2.0 ** torch.arange(n_harmonic_functions, dtype=x.dtype)
        e = (x[..., None] * freqs).reshape(*x.shape[:-1], -1)
        return torch.cat([e.sin(), e.cos(), x], dim=-1)

    return embed


def install_pytorch3d_stand_ins():
    root = types.ModuleType("pytorch3d")
    io = types.ModuleType("pytorch3d.io")
    io.load_obj = _load_obj
    structures = types.ModuleType("pytorch3d.structures")
    structures.Meshes = _Meshes
    renderer = types.ModuleType("pytorch3d.renderer")
    for name in ["CamerasBase", "RasterizationSettings", "PointLights", "TexturesVertex",
                 "BlendParams", "TexturesUV", "SoftPhongShader", "MeshRasterizer", "MeshRenderer"]:
        setattr(renderer, name, type(name, (_Unavailable,), {}))
    rasterizer = types.ModuleType("pytorch3d.renderer.mesh.rasterizer")
    rasterizer.Fragments = type("Fragments", (_Unavailable,), {})
    rasterizer.rasterize_meshes = _Unavailable
    harmonic = types.ModuleType("pytorch3d.renderer.implicit.harmonic_embedding")
    harmonic.HarmonicEmbedding = harmonic_embedding
    # The CUDA splatting extension (GPU build only; models/UbodyAvatar/gaussian_render.py).
    splatter = types.ModuleType("diff_gaussian_rasterization_32")
    for name in ["GaussianRasterizationSettings", "GaussianRasterizer_32"]:
        setattr(splatter, name, type(name, (_Unavailable,), {}))
    root.io, root.structures, root.renderer = io, structures, renderer
    sys.modules.update({
        "pytorch3d": root, "pytorch3d.io": io, "pytorch3d.structures": structures,
        "pytorch3d.renderer": renderer, "pytorch3d.renderer.mesh": types.ModuleType("mesh"),
        "pytorch3d.renderer.mesh.rasterizer": rasterizer,
        "pytorch3d.renderer.implicit": types.ModuleType("implicit"),
        "pytorch3d.renderer.implicit.harmonic_embedding": harmonic,
        # open3d only writes point-cloud PLYs (ubody_gaussian.py export paths).
        "open3d": types.ModuleType("open3d"),
        "diff_gaussian_rasterization_32": splatter,
    })


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
