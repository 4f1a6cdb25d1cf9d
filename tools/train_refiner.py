"""Trains the default refiner and exports it to ONNX (assets/refiner/default_refiner.onnx).

The pairs come from the project itself (`guava refiner-pairs`, guava::eval::pairs): synthetic
subjects reconstructed in default mode from a front photo, seen from other views and poses. The
input is the splatting pass's image (RGB, source confidence, alpha, on black); the target is the
subject drawn antialiased (premultiplied RGB, coverage). The network is a small U-Net that adds a
correction to the input's RGB and alpha; it is fully convolutional, so it runs at any size that
is a multiple of 4.

    cargo run --release -p guava-cli -- refiner-pairs --out /tmp/refiner/train --split train
    cargo run --release -p guava-cli -- refiner-pairs --out /tmp/refiner/held --split held-out
    python tools/train_refiner.py --train /tmp/refiner/train --held /tmp/refiner/held \
        --out assets/refiner/default_refiner.onnx

Needs PyTorch (CPU; 2.5.1 used), onnx and numpy; not CI. Seeded (--seed); the recipe, the seed,
the parameter count and the held-out PSNR of raw and refined are written into the model's
metadata. About 6 minutes on two cores (longer, it learned to paint hair over real heads seen
from behind; docs/refiner.md).
"""

import argparse
import json
import math
import time

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F


class Refiner(nn.Module):
    """Full resolution 16 channels, half 32, quarter 64; skip connections; a residual output."""

    def __init__(self, width=16):
        super().__init__()
        w1, w2, w3 = width, 2 * width, 4 * width
        self.enc0 = nn.Sequential(nn.Conv2d(5, w1, 3, padding=1), nn.ReLU(), nn.Conv2d(w1, w1, 3, padding=1), nn.ReLU())
        self.enc1 = nn.Sequential(nn.Conv2d(w1, w2, 3, stride=2, padding=1), nn.ReLU(), nn.Conv2d(w2, w2, 3, padding=1), nn.ReLU())
        self.enc2 = nn.Sequential(nn.Conv2d(w2, w3, 3, stride=2, padding=1), nn.ReLU(), nn.Conv2d(w3, w3, 3, padding=1), nn.ReLU())
        self.dec1 = nn.Sequential(nn.Conv2d(w3 + w2, w2, 3, padding=1), nn.ReLU(), nn.Conv2d(w2, w2, 3, padding=1), nn.ReLU())
        self.dec0 = nn.Sequential(nn.Conv2d(w2 + w1, w1, 3, padding=1), nn.ReLU())
        self.out = nn.Conv2d(w1, 4, 3, padding=1)
        nn.init.zeros_(self.out.weight)
        nn.init.zeros_(self.out.bias)

    def forward(self, splat):
        e0 = self.enc0(splat)
        e1 = self.enc1(e0)
        e2 = self.enc2(e1)
        d1 = self.dec1(torch.cat([F.interpolate(e2, scale_factor=2.0, mode="bilinear", align_corners=False), e1], 1))
        d0 = self.dec0(torch.cat([F.interpolate(d1, scale_factor=2.0, mode="bilinear", align_corners=False), e0], 1))
        base = torch.cat([splat[:, 0:3], splat[:, 4:5]], 1)
        return torch.clamp(base + self.out(d0), 0.0, 1.0)


def load(folder):
    x = np.load(f"{folder}/inputs.npy")
    y = np.load(f"{folder}/targets.npy")
    return torch.from_numpy(x), torch.from_numpy(y)


def as_float(t):
    return t.float() / 255.0


def psnr_over_people(pred, target):
    """PSNR of premultiplied RGB over each image's person box (target coverage > 0.5), as
    guava eval measures; the mean over images."""
    out = []
    for p, t in zip(pred, target):
        m = t[3] > 0.5
        ys, xs = torch.nonzero(m, as_tuple=True)
        if len(ys) == 0:
            continue
        y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
        mse = ((p[:3, y0:y1, x0:x1] - t[:3, y0:y1, x0:x1]) ** 2).mean().item()
        out.append(10 * math.log10(1.0 / max(mse, 1e-12)))
    return float(np.mean(out))


def evaluate(model, x, y):
    model.eval()
    raw, refined = [], []
    with torch.no_grad():
        for i in range(0, len(x), 8):
            xi, yi = as_float(x[i : i + 8]), as_float(y[i : i + 8])
            pred = model(xi)
            raw.append(torch.cat([xi[:, :3], xi[:, 4:5]], 1))
            refined.append(pred)
            del xi
    target = as_float(y)
    model.train()
    return psnr_over_people(torch.cat(raw), target), psnr_over_people(torch.cat(refined), target)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--train", required=True)
    ap.add_argument("--held", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--minutes", type=float, default=6.0)
    ap.add_argument("--crop", type=int, default=128)
    ap.add_argument("--batch", type=int, default=8)
    args = ap.parse_args()

    torch.manual_seed(args.seed)
    np.random.seed(args.seed)
    torch.set_num_threads(max(1, torch.get_num_threads()))
    x, y = load(args.train)
    hx, hy = load(args.held)
    model = Refiner()
    params = sum(p.numel() for p in model.parameters())
    print(f"{len(x)} training pairs, {len(hx)} held out; {params} parameters")
    opt = torch.optim.Adam(model.parameters(), lr=2e-3)
    budget = args.minutes * 60
    start = time.time()
    step = 0
    n, side = len(x), x.shape[-1]
    while time.time() - start < budget:
        frac = (time.time() - start) / budget
        for g in opt.param_groups:
            g["lr"] = 2e-3 * 0.5 * (1 + math.cos(math.pi * frac))
        idx = np.random.randint(0, n, args.batch)
        xs, ys = [], []
        for i in idx:
            # Crops that hold some of the person.
            for _ in range(8):
                cy, cx = np.random.randint(0, side - args.crop + 1, 2)
                cy, cx = cy - cy % 4, cx - cx % 4
                if y[i, 3, cy : cy + args.crop, cx : cx + args.crop].float().mean() > 0.1 * 255:
                    break
            xs.append(x[i, :, cy : cy + args.crop, cx : cx + args.crop])
            ys.append(y[i, :, cy : cy + args.crop, cx : cx + args.crop])
        xb, yb = as_float(torch.stack(xs)), as_float(torch.stack(ys))
        pred = model(xb)
        loss = F.l1_loss(pred[:, :3], yb[:, :3]) + 0.5 * F.l1_loss(pred[:, 3:], yb[:, 3:])
        opt.zero_grad()
        loss.backward()
        opt.step()
        step += 1
        if step % 200 == 0:
            print(f"step {step} ({time.time() - start:.0f} s): loss {loss.item():.4f}", flush=True)
        if step % 1000 == 0:
            raw, refined = evaluate(model, hx, hy)
            print(f"  held out: raw {raw:.2f} dB, refined {refined:.2f} dB", flush=True)
    raw, refined = evaluate(model, hx, hy)
    print(f"done after {step} steps: held out raw {raw:.2f} dB, refined {refined:.2f} dB")

    model.eval()
    dummy = torch.zeros(1, 5, 64, 64)
    torch.onnx.export(
        model,
        dummy,
        args.out,
        input_names=["splat"],
        output_names=["refined"],
        dynamic_axes={"splat": {2: "height", 3: "width"}, "refined": {2: "height", 3: "width"}},
        opset_version=17,
    )
    import onnx

    m = onnx.load(args.out)
    recipe = {
        "pairs": "guava refiner-pairs (guava::eval::pairs): train split, held-out split",
        "seed": args.seed,
        "steps": step,
        "crop": args.crop,
        "batch": args.batch,
        "optimizer": "Adam 2e-3, cosine to 0 over the time budget",
        "loss": "L1(RGB) + 0.5 L1(alpha)",
        "parameters": params,
        "held_out_psnr_db": {"raw": round(raw, 2), "refined": round(refined, 2)},
    }
    for key, value in [
        ("description", f"default refiner ({params} parameters, trained on synthetic subjects)"),
        ("recipe", json.dumps(recipe)),
    ]:
        entry = m.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.save(m, args.out)
    print(json.dumps(recipe, indent=1))


if __name__ == "__main__":
    main()
