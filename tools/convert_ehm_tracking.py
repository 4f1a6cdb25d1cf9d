#!/usr/bin/env python3
"""EHM-Tracker output → a guava-rs tracking file ("guava-rs tracking 1", docs/tracking-format.md).

    python3 tools/convert_ehm_tracking.py TRACKED_DIR --out motion.json [--video ID] [--fps 30]

TRACKED_DIR holds what EHM-Tracker writes (layout as GUAVA's dataset/data_loader.py reads it):
  optim_tracking_ehm.pkl  {video_id: {frame_key: record}} (merged dataset) or {frame_key: record}
                          (one tracked video or image)
  id_share_params.pkl     {video_id: params} or params
  videos_info.json        {video_id: {"frames_keys": [...], "frames_num": N}} (optional for the
                          per-video form; frame keys are then sorted)

Mapping (EHM.forward's conventions; the EHM body in guava-rs uses SMPL-X joint names):
  smplx_coeffs.global_pose [1,3]         → pelvis
  smplx_coeffs.body_pose [21,3]          → SMPL-X joints 1…21
  flame_coeffs.jaw_params [3]            → jaw (EHM poses the jaw on the FLAME head)
  flame_coeffs.eye_pose_params [6]       → left_eye_smplhf, right_eye_smplhf
  smplx_coeffs.left/right_hand_pose      → the 15 finger joints of each hand
  smplx_coeffs.exp [50]                  → expression_000…
  flame_coeffs.expression_params [50]    → flame_expression_000…
  flame_coeffs.eyelid_params [2]         → eyelid_left, eyelid_right
  smplx_coeffs.camera_RT_params [3,4]    → camera.w2c = diag(-1,-1,1)·[R|T] (PyTorch3D → OpenCV
                                            axes, data_loader.py), invtanfov 24 (GUAVA's config)
  id_share: smplx_shape → shape_…, flame_shape → flame_shape_…, joints_offset/head_scale/
            hand_scale → identity.ehm (each stored with a leading axis of 1, taken at [0])
Ignored, as GUAVA ignores them at inference: flame pose_params/neck_pose_params (EHM zeroes
them), body_cam, crops, landmarks. EHM-Tracker records no frame rate: --fps (default 30, the
rate of its own preview videos).

Needs NumPy (the pickles hold NumPy arrays). Writes through a temporary file, then renames.
"""

import argparse
import json
import os
import pickle
import sys
from pathlib import Path

import numpy as np

SMPLX_JOINTS = [
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle",
    "right_ankle", "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar",
    "head", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist",
    "right_wrist", "jaw", "left_eye_smplhf", "right_eye_smplhf",
] + [f"{side}_{finger}{k}" for side in ("left", "right")
     for finger in ("index", "middle", "pinky", "ring", "thumb") for k in (1, 2, 3)]
GUAVA_INVTANFOV = 24.0
PYTORCH3D_TO_OPENCV = np.diag([-1.0, -1.0, 1.0])


class ConversionError(Exception):
    pass


def array(record, path, where, shape):
    """record[path...] as float64 of `shape` (size-1 axes squeezed as data_loader does)."""
    value = record
    for key in path:
        if not isinstance(value, dict) or key not in value:
            raise ConversionError(f"{where}: {'.'.join(path)}: missing")
        value = value[key]
    a = np.asarray(value, dtype=np.float64)
    if a.size != int(np.prod(shape)):
        raise ConversionError(f"{where}: {'.'.join(path)}: shape {list(a.shape)}, expected {list(shape)}")
    a = a.reshape(shape)
    if not np.all(np.isfinite(a)):
        raise ConversionError(f"{where}: {'.'.join(path)}: not finite")
    return a


def load_pickle(path):
    try:
        with open(path, "rb") as f:
            return pickle.load(f)
    except (OSError, pickle.UnpicklingError, EOFError) as e:
        raise ConversionError(f"{path}: {e}") from e


def pick_video(tracked, id_share, videos_info, video, root):
    """(frame records by key, identity params, ordered frame keys, video id) for either layout."""
    per_video = all(isinstance(v, dict) and "smplx_coeffs" in v for v in tracked.values())
    if per_video:
        frames, video = tracked, video or root.name
    else:
        if video is None:
            if len(tracked) != 1:
                raise ConversionError(f"{root}: {len(tracked)} videos ({', '.join(sorted(tracked))}); pick one with --video")
            video = next(iter(tracked))
        if video not in tracked:
            raise ConversionError(f"{root}/optim_tracking_ehm.pkl: no video {video!r}")
        frames = tracked[video]
    identity = id_share if "smplx_shape" in id_share else id_share.get(video)
    if identity is None:
        raise ConversionError(f"{root}/id_share_params.pkl: no entry for video {video!r}")
    if videos_info is not None and video in videos_info:
        keys = list(videos_info[video]["frames_keys"])
    else:
        keys = sorted(frames)
    missing = [k for k in keys if k not in frames]
    if missing:
        raise ConversionError(f"{root}/optim_tracking_ehm.pkl: frames listed in videos_info.json are missing: {missing[:5]}")
    return frames, identity, keys, video


def convert(root, video=None, fps=30.0):
    root = Path(root)
    tracked = load_pickle(root / "optim_tracking_ehm.pkl")
    id_share = load_pickle(root / "id_share_params.pkl")
    info_path = root / "videos_info.json"
    videos_info = json.loads(info_path.read_text()) if info_path.exists() else None
    frames, identity, keys, video = pick_video(tracked, id_share, videos_info, video, root)

    where = f"{root}/id_share_params.pkl"

    def shared(name, shape=None):
        """An identity array; each is stored with a leading axis of 1 (data_loader takes [0])."""
        if name not in identity:
            raise ConversionError(f"{where}: {name}: missing")
        v = np.asarray(identity[name])[0]
        return array({name: v}, [name], where, shape or (v.size,))

    smplx_shape, flame_shape = shared("smplx_shape"), shared("flame_shape")
    ehm = {
        "joints_offset": shared("joints_offset", (55, 3)),
        "head_scale": shared("head_scale", (3,)),
        "hand_scale": shared("hand_scale", (3,)),
    }
    parameters = ([f"expression_{i:03d}" for i in range(50)] + [f"flame_expression_{i:03d}" for i in range(50)]
                  + ["eyelid_left", "eyelid_right"])
    out_frames = []
    for key in keys:
        rec = frames[key]
        w = f"{root}/optim_tracking_ehm.pkl: frame {key}"
        rotations = np.zeros((55, 3))
        rotations[0] = array(rec, ["smplx_coeffs", "global_pose"], w, (3,))
        rotations[1:22] = array(rec, ["smplx_coeffs", "body_pose"], w, (21, 3))
        rotations[22] = array(rec, ["flame_coeffs", "jaw_params"], w, (3,))
        rotations[23:25] = array(rec, ["flame_coeffs", "eye_pose_params"], w, (2, 3))
        rotations[25:40] = array(rec, ["smplx_coeffs", "left_hand_pose"], w, (15, 3))
        rotations[40:55] = array(rec, ["smplx_coeffs", "right_hand_pose"], w, (15, 3))
        values = np.concatenate([
            array(rec, ["smplx_coeffs", "exp"], w, (50,)),
            array(rec, ["flame_coeffs", "expression_params"], w, (50,)),
            array(rec, ["flame_coeffs", "eyelid_params"], w, (2,)),
        ])
        rt = array(rec, ["smplx_coeffs", "camera_RT_params"], w, (3, 4))
        w2c = PYTORCH3D_TO_OPENCV @ rt
        out_frames.append({
            "translation": [0.0, 0.0, 0.0],
            "rotations": [[float(x) for x in r] for r in rotations.astype(np.float32)],
            "values": [float(x) for x in values.astype(np.float32)],
            "camera": {"w2c": [[float(x) for x in row] for row in w2c.astype(np.float32)],
                       "invtanfov": GUAVA_INVTANFOV},
        })
    header = {
        "format": "guava-rs tracking 1",
        "body": "smplx",
        "fps": float(fps),
        "source": f"EHM-Tracker {root.name}/{video} via tools/convert_ehm_tracking.py",
        "joints": SMPLX_JOINTS,
        "parameters": parameters,
        "identity": {
            "parameters": {
                **{f"shape_{i:03d}": float(v) for i, v in enumerate(smplx_shape.astype(np.float32))},
                **{f"flame_shape_{i:03d}": float(v) for i, v in enumerate(flame_shape.astype(np.float32))},
            },
            "ehm": {k: v.astype(np.float32).tolist() for k, v in ehm.items()},
        },
    }
    text = json.dumps(header, indent=2)[:-2] + ',\n  "frames": [\n'
    text += ",\n".join("    " + json.dumps(f, separators=(",", ":")) for f in out_frames)
    return text + "\n  ]\n}\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("tracked_dir")
    parser.add_argument("--out", required=True)
    parser.add_argument("--video", help="video id, when the pickle holds several")
    parser.add_argument("--fps", type=float, default=30.0, help="frame rate of the tracked frames")
    args = parser.parse_args()
    try:
        text = convert(args.tracked_dir, args.video, args.fps)
    except ConversionError as e:
        sys.exit(f"convert_ehm_tracking: {e}")
    out = Path(args.out)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, out)
    print(f"wrote {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
