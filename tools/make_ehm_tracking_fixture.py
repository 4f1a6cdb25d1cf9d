#!/usr/bin/env python3
"""Writes a synthetic EHM-Tracker output with the real key layout (tests/data/ehm_tracker/) and the
raw values it holds (expected.npz), for tests/tracking_convert.rs, which runs
tools/convert_ehm_tracking.py on it and checks every mapped value.

Layout as GUAVA's dataset/data_loader.py reads a merged dataset: optim_tracking_ehm.pkl
{video: {frame: record}}, id_share_params.pkl {video: params}, videos_info.json; records carry the
keys EHM-Tracker writes (ehm_refiner.py / flame_refiner.py), including ones the converter ignores.
Two videos, so the converter's --video choice is exercised. NumPy only; deterministic:

    python3 tools/make_ehm_tracking_fixture.py
"""

import json
import pickle
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent.parent / "tests" / "data" / "ehm_tracker"


def rotation(rng, scale):
    """A rotation matrix near identity (Rodrigues of a small random axis-angle)."""
    v = rng.normal(size=3) * scale
    theta = np.linalg.norm(v)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]]) / theta
    return np.eye(3) + np.sin(theta) * k + (1 - np.cos(theta)) * k @ k


def main():
    rng = np.random.default_rng(20261123)
    f32 = lambda *shape, s=0.3: (rng.normal(size=shape) * s).astype(np.float32)  # noqa: E731
    tracked, id_share, info, expected = {}, {}, {}, {}
    for video, count in [("clip_a", 3), ("clip_b", 2)]:
        keys = [f"frame_{i:06d}" for i in range(count)]
        info[video] = {"frames_num": count, "frames_keys": keys}
        tracked[video] = {}
        raw = {k: [] for k in ["global_pose", "body_pose", "jaw", "eyes", "left_hand", "right_hand",
                               "exp", "flame_exp", "eyelids", "rt"]}
        for key in keys:
            s, tx, ty = 1.2 + rng.random(), rng.normal() * 0.05, rng.normal() * 0.05
            r = (np.diag([-1.0, -1.0, 1.0]) @ rotation(rng, 0.05)).astype(np.float32)
            rt = np.concatenate([r, np.array([[-tx], [-ty], [24.0 / s]], dtype=np.float32)], 1)
            smplx = {
                "exp": f32(50), "global_pose": f32(1, 3), "body_pose": f32(21, 3),
                "body_cam": np.array([s, tx, ty], dtype=np.float32), "camera_RT_params": rt,
                "left_hand_pose": f32(1, 15, 3), "right_hand_pose": f32(1, 15, 3),
            }
            flame = {
                "expression_params": f32(50), "jaw_params": f32(3, s=0.1), "pose_params": f32(3),
                "neck_pose_params": np.zeros(3, np.float32), "eye_pose_params": f32(6, s=0.1),
                "eyelid_params": rng.random(2).astype(np.float32), "camera_RT_params": f32(3, 4),
                "cam": f32(3),
            }
            crop = {"M_o2c": f32(3, 3), "M_c2o": f32(3, 3)}
            tracked[video][key] = {
                "smplx_coeffs": smplx, "flame_coeffs": flame,
                "body_crop": {**crop, "M_o2c-hd": f32(3, 3), "M_c2o-hd": f32(3, 3)},
                "head_crop": crop, "left_hand_crop": crop, "right_hand_crop": crop,
                "dwpose_rlt": {"keypoints": f32(133, 2), "scores": rng.random(133).astype(np.float32)},
            }
            for name, value in [("global_pose", smplx["global_pose"]), ("body_pose", smplx["body_pose"]),
                                ("jaw", flame["jaw_params"]), ("eyes", flame["eye_pose_params"]),
                                ("left_hand", smplx["left_hand_pose"]), ("right_hand", smplx["right_hand_pose"]),
                                ("exp", smplx["exp"]), ("flame_exp", flame["expression_params"]),
                                ("eyelids", flame["eyelid_params"]), ("rt", rt)]:
                raw[name].append(value)
        id_share[video] = {
            "smplx_shape": f32(1, 200), "flame_shape": f32(1, 300),
            "joints_offset": f32(1, 55, 3, s=0.01), "head_scale": (1 + f32(1, 3, s=0.05)),
            "hand_scale": (1 + f32(1, 3, s=0.05)), "left_mano_shape": f32(1, 10), "right_mano_shape": f32(1, 10),
        }
        if video == "clip_a":
            expected = {k: np.stack(v) for k, v in raw.items()}
            expected.update({k: id_share[video][k][0] for k in
                             ["smplx_shape", "flame_shape", "joints_offset", "head_scale", "hand_scale"]})
    OUT.mkdir(parents=True, exist_ok=True)
    for name, value in [("optim_tracking_ehm.pkl", tracked), ("id_share_params.pkl", id_share)]:
        with open(OUT / name, "wb") as f:
            pickle.dump(value, f, protocol=4)
    (OUT / "videos_info.json").write_text(json.dumps(info, indent=4) + "\n")
    np.savez_compressed(OUT / "expected.npz", **expected)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
