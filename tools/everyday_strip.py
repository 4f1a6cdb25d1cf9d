#!/usr/bin/env python3
"""Renders docs/img/everyday_photos.jpg: each everyday photo (tests/data/photos, and the demo
portrait with its tracking), then its avatar from the front, the side and the back, refined, as
docs/reconstruction.md describes. Needs the `guava` binary (cargo build -p guava-cli), Pillow.

    python3 tools/everyday_strip.py [--guava target/debug/guava] [--out docs/img/everyday_photos.jpg]
"""

import argparse
import os
import subprocess
import tempfile

from PIL import Image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PHOTOS = [
    ("assets/demo_portrait.png", "assets/demo_portrait.json"),
    ("tests/data/photos/two_people.jpg", None),
    ("tests/data/photos/long_hair.jpg", None),
    ("tests/data/photos/hand_over_face.jpg", None),
    ("tests/data/photos/face_crop.png", None),
    ("tests/data/photos/grace_hopper.jpg", None),
]
CELL = 196


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--guava", default=os.path.join(ROOT, "target/debug/guava"))
    parser.add_argument("--out", default=os.path.join(ROOT, "docs/img/everyday_photos.jpg"))
    args = parser.parse_args()
    strip = Image.new("RGB", (4 * CELL, len(PHOTOS) * CELL), (128, 128, 128))
    with tempfile.TemporaryDirectory() as tmp:
        for row, (photo, tracking) in enumerate(PHOTOS):
            avatar = os.path.join(tmp, f"{row}.guava")
            command = [args.guava, "reconstruct", "--image", os.path.join(ROOT, photo)]
            if tracking:
                command += ["--tracking", os.path.join(ROOT, tracking)]
            subprocess.run(command + ["--out", avatar], check=True, capture_output=True)
            thumb = Image.open(os.path.join(ROOT, photo)).convert("RGB")
            scale = CELL / max(thumb.size)
            thumb = thumb.resize(
                (round(thumb.width * scale), round(thumb.height * scale)), Image.LANCZOS)
            strip.paste(thumb, ((CELL - thumb.width) // 2, row * CELL + (CELL - thumb.height) // 2))
            for column, yaw in enumerate([0, 90, 180], start=1):
                png = os.path.join(tmp, f"{row}_{yaw}.png")
                subprocess.run(
                    [args.guava, "render", "--avatar", avatar, "--source-pose", "--refine",
                     "--fov", "25", "--yaw", str(yaw), "--out", png],
                    check=True, capture_output=True)
                view = Image.open(png).convert("RGB").resize((CELL, CELL), Image.LANCZOS)
                strip.paste(view, (column * CELL, row * CELL))
    strip.save(args.out, quality=85)
    print(f"→ {args.out}")


if __name__ == "__main__":
    main()
