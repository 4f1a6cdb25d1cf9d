#!/usr/bin/env python3
"""Writes the parity fixtures of the published splat formats we read, decoded by PlayCanvas's own
tool (splat-transform).

PlayCanvas's compressed PLY (SuperSplat's "compressed.ply": chunks of 256 splats with min/max
bounds, one packed uint32 each for position, rotation, scale and colour, optional 8-bit SH) is
a common way splats are published. This script makes a small 3DGS PLY of 1,000 random Gaussians
with degree-1 SH (so the file carries an `sh` element after the vertices), compresses it with
`@playcanvas/splat-transform`, and has the same tool decode the compressed file back into a
standard 3DGS PLY. tests/ply.rs reads the compressed file with our reader and compares it with
the tool's decoding, attribute by attribute.

antimatter15's `.splat` (32 bytes a splat, no header): 256 other random Gaussians are kept as a
standard PLY (`splat_source.ply`) and packed into `cloud.splat` here as his converter packs them
(colour and opacity times 255 truncated, each unit-quaternion component as 128 + 128·q
truncated); splat-transform decodes that file to `splat_decoded.ply`.

Writes tests/data/splat_transform/{cloud.compressed.ply, decoded.ply} (the compressed source is
regenerated from its seed, not kept) and {splat_source.ply, cloud.splat, splat_decoded.ply}.
Run once (needs node with npx; fetches the pinned package from npm; CI does not run this):
    python3 tools/make_splat_file_fixtures.py
"""
import pathlib
import subprocess
import tempfile

import numpy as np

SPLAT_TRANSFORM = "@playcanvas/splat-transform@3.7.0"
OUT = pathlib.Path(__file__).resolve().parent.parent / "tests" / "data" / "splat_transform"
COUNT = 1000  # four chunks of 256, the last one partial
SH_REST = 9  # degree 1: three coefficients per colour channel


SH_C0 = 0.28209479177387814


def write_3dgs_ply(path: pathlib.Path, rng: np.random.Generator, count: int, sh_rest: int) -> dict:
    names = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2"]
    names += [f"f_rest_{i}" for i in range(sh_rest)]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    cols = {
        # Spread over a few units with a dense core, as scenes are.
        "x": rng.normal(0.0, 1.5, count),
        "y": rng.normal(0.0, 0.7, count),
        "z": rng.uniform(-3.0, 3.0, count),
        "opacity": rng.normal(0.0, 3.0, count),  # logits: from nearly clear to nearly opaque
    }
    for c in range(3):
        cols[f"f_dc_{c}"] = rng.normal(0.0, 1.0, count)
        cols[f"scale_{c}"] = rng.uniform(-6.0, -1.0, count)  # logs: needles to blobs
    for i in range(sh_rest):
        cols[f"f_rest_{i}"] = rng.normal(0.0, 0.3, count)
    quats = rng.normal(0.0, 1.0, (count, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    for i in range(4):
        cols[f"rot_{i}"] = quats[:, i]
    table = np.stack([cols[n] for n in names], axis=1).astype("<f4")
    header = "ply\nformat binary_little_endian 1.0\n"
    header += "comment random 3DGS cloud, tools/make_splat_file_fixtures.py\n"
    header += f"element vertex {count}\n"
    header += "".join(f"property float {n}\n" for n in names) + "end_header\n"
    path.write_bytes(header.encode() + table.tobytes())
    return {n: table[:, i].astype(np.float64) for i, n in enumerate(names)}


def write_dot_splat(path: pathlib.Path, cols: dict) -> None:
    count = len(cols["x"])
    record = np.zeros((count, 32), dtype=np.uint8)
    floats = np.stack([cols[n] for n in ["x", "y", "z"]] +
                      [np.exp(cols[f"scale_{c}"]) for c in range(3)], axis=1).astype("<f4")
    record[:, :24] = floats.view(np.uint8).reshape(count, 24)
    rgba = [0.5 + SH_C0 * cols[f"f_dc_{c}"] for c in range(3)]
    rgba.append(1.0 / (1.0 + np.exp(-cols["opacity"])))
    record[:, 24:28] = (np.stack(rgba, axis=1) * 255).clip(0, 255).astype(np.uint8)
    q = np.stack([cols[f"rot_{i}"] for i in range(4)], axis=1)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    record[:, 28:32] = (q * 128 + 128).clip(0, 255).astype(np.uint8)
    path.write_bytes(record.tobytes())


def splat_transform(*args: str) -> None:
    subprocess.run(["npx", "--yes", SPLAT_TRANSFORM, "--quiet", "--overwrite", *args], check=True)


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    compressed, decoded = OUT / "cloud.compressed.ply", OUT / "decoded.ply"
    with tempfile.TemporaryDirectory() as tmp:
        source = pathlib.Path(tmp) / "source.ply"
        write_3dgs_ply(source, np.random.default_rng(20261203), COUNT, SH_REST)
        # splat-transform picks the writer by the output's extension: .compressed.ply, then the
        # standard 3DGS layout for a plain .ply. It reorders the splats (Morton order).
        splat_transform(str(source), str(compressed))
    splat_transform(str(compressed), str(decoded))

    cols = write_3dgs_ply(OUT / "splat_source.ply", np.random.default_rng(20261204), 256, 0)
    write_dot_splat(OUT / "cloud.splat", cols)
    splat_transform(str(OUT / "cloud.splat"), str(OUT / "splat_decoded.ply"))
    for f in sorted(OUT.iterdir()):
        print(f"{f.relative_to(OUT.parent.parent.parent)}: {f.stat().st_size} bytes")


if __name__ == "__main__":
    main()
