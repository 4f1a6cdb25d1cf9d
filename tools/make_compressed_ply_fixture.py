#!/usr/bin/env python3
"""Writes the compressed-PLY parity fixture with PlayCanvas's own tool (splat-transform).

PlayCanvas's compressed PLY (SuperSplat's "compressed.ply": chunks of 256 splats with min/max
bounds, one packed uint32 each for position, rotation, scale and colour, optional 8-bit SH) is
a common way splats are published. This script makes a small 3DGS PLY of 1,000 random Gaussians
with degree-1 SH (so the file carries an `sh` element after the vertices), compresses it with
`@playcanvas/splat-transform`, and has the same tool decode the compressed file back into a
standard 3DGS PLY. tests/ply.rs reads the compressed file with our reader and compares it with
the tool's decoding, attribute by attribute.

Writes tests/data/splat_transform/{cloud.compressed.ply, decoded.ply} (the source cloud is
regenerated from its seed, not kept).
Run once (needs node with npx; fetches the pinned package from npm; CI does not run this):
    python3 tools/make_compressed_ply_fixture.py
"""
import pathlib
import subprocess
import tempfile

import numpy as np

SPLAT_TRANSFORM = "@playcanvas/splat-transform@3.7.0"
OUT = pathlib.Path(__file__).resolve().parent.parent / "tests" / "data" / "splat_transform"
COUNT = 1000  # four chunks of 256, the last one partial
SH_REST = 9  # degree 1: three coefficients per colour channel


def write_3dgs_ply(path: pathlib.Path, rng: np.random.Generator) -> None:
    names = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2"]
    names += [f"f_rest_{i}" for i in range(SH_REST)]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    cols = {
        # Spread over a few units with a dense core, as scenes are.
        "x": rng.normal(0.0, 1.5, COUNT),
        "y": rng.normal(0.0, 0.7, COUNT),
        "z": rng.uniform(-3.0, 3.0, COUNT),
        "opacity": rng.normal(0.0, 3.0, COUNT),  # logits: from nearly clear to nearly opaque
    }
    for c in range(3):
        cols[f"f_dc_{c}"] = rng.normal(0.0, 1.0, COUNT)
        cols[f"scale_{c}"] = rng.uniform(-6.0, -1.0, COUNT)  # logs: needles to blobs
    for i in range(SH_REST):
        cols[f"f_rest_{i}"] = rng.normal(0.0, 0.3, COUNT)
    quats = rng.normal(0.0, 1.0, (COUNT, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    for i in range(4):
        cols[f"rot_{i}"] = quats[:, i]
    table = np.stack([cols[n] for n in names], axis=1).astype("<f4")
    header = "ply\nformat binary_little_endian 1.0\n"
    header += "comment random 3DGS cloud, tools/make_compressed_ply_fixture.py\n"
    header += f"element vertex {COUNT}\n"
    header += "".join(f"property float {n}\n" for n in names) + "end_header\n"
    path.write_bytes(header.encode() + table.tobytes())


def splat_transform(*args: str) -> None:
    subprocess.run(["npx", "--yes", SPLAT_TRANSFORM, "--quiet", "--overwrite", *args], check=True)


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    compressed, decoded = OUT / "cloud.compressed.ply", OUT / "decoded.ply"
    with tempfile.TemporaryDirectory() as tmp:
        source = pathlib.Path(tmp) / "source.ply"
        write_3dgs_ply(source, np.random.default_rng(20261203))
        # splat-transform picks the writer by the output's extension: .compressed.ply, then the
        # standard 3DGS layout for a plain .ply. It reorders the splats (Morton order).
        splat_transform(str(source), str(compressed))
    splat_transform(str(compressed), str(decoded))
    for f in sorted(OUT.iterdir()):
        print(f"{f.relative_to(OUT.parent.parent.parent)}: {f.stat().st_size} bytes")


if __name__ == "__main__":
    main()
