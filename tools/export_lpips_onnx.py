"""LPIPS (Zhang et al. 2018, the `lpips` package, BSD-2-Clause) as one ONNX model for `guava eval
--lpips`, the perceptual metric of GUAVA's tables:

    lpips.onnx   a [1,3,H,W], b [1,3,H,W]  (RGB in [-1, 1], any H, W from 32 up)
                 -> distance [1,1,1,1]      (0 for identical images; higher is less alike)

The distance is the `lpips` package's own forward (version 0.1: its scaling layer, the
backbone's five feature maps unit-normalised over channels, squared differences weighted by its
learned linear layers, averaged over space, summed), traced with dynamic height and width.

The learned linear layers ship inside the `lpips` wheel (weights/v0.1/alex.pth). The AlexNet
backbone does not: torchvision downloads it on first use, which these machines cannot, so it is
given by file:

    --alexnet FILE   torchvision's `alexnet-owt-7be5be79.pth` (ImageNet weights) -> the metric
                     GUAVA's paper reports (LPIPS-Alex, as its evaluation code computes it)
    --tiny SEED      a test fixture with LPIPS's structure but a two-layer random backbone and
                     random linear layers (a few KB): the contract and the arithmetic, not the
                     metric

`--fixture DIR` also writes two test images and PyTorch's distances between them, which
tests/lpips.rs matches through ONNX Runtime. What the tests ship was made with

    python tools/export_lpips_onnx.py --tiny 0 --out tests/data/lpips/tiny_lpips.onnx \
        --fixture tests/data/lpips

Needs PyTorch (CPU; 2.5.1 used), torchvision, lpips==0.1.4, onnx, onnxruntime, numpy, Pillow;
not CI.
"""

import argparse
import json
import os

import numpy as np
import torch
from torch import nn


class TinyBackbone(nn.Module):
    """Two conv + ReLU stages, as lpips' backbones return their stages' outputs."""

    def __init__(self):
        super().__init__()
        self.slice1 = nn.Sequential(nn.Conv2d(3, 8, 3, stride=2, padding=1), nn.ReLU())
        self.slice2 = nn.Sequential(nn.Conv2d(8, 16, 3, stride=2, padding=1), nn.ReLU())

    def forward(self, x):
        h1 = self.slice1(x)
        return [h1, self.slice2(h1)]


def lpips_model(args):
    import lpips

    if args.tiny is not None:
        torch.manual_seed(args.tiny)
        model = lpips.LPIPS(net="alex", pretrained=True, pnet_rand=True, verbose=False)
        model.net = TinyBackbone()
        model.chns = [8, 16]
        model.L = 2
        model.lins = nn.ModuleList([lpips.NetLinLayer(c, use_dropout=False) for c in model.chns])
        for lin in model.lins:
            # Non-negative weights, as LPIPS's training keeps them.
            nn.init.uniform_(lin.model[-1].weight, 0.0, 0.2)
        return model.eval(), f"tiny random backbone, seed {args.tiny}"
    import torchvision

    model = lpips.LPIPS(net="alex", pretrained=True, pnet_rand=True, verbose=False)
    alexnet = torchvision.models.alexnet()
    alexnet.load_state_dict(torch.load(args.alexnet, map_location="cpu"))
    # lpips' slices hold torchvision's feature layers under their indices.
    for stage in [model.net.slice1, model.net.slice2, model.net.slice3, model.net.slice4, model.net.slice5]:
        for name, layer in stage.named_children():
            layer.load_state_dict(alexnet.features[int(name)].state_dict())
    return model.eval(), f"AlexNet from {os.path.basename(args.alexnet)}"


class Distance(nn.Module):
    def __init__(self, model):
        super().__init__()
        self.model = model

    def forward(self, a, b):
        return self.model(a, b)


def fixture_images():
    """Two 48x64 test images: a smooth gradient with a disc, and the same shifted and tinted."""
    y, x = np.mgrid[0:48, 0:64].astype(np.float32)
    a = np.stack([x / 63, y / 47, 0.5 + 0.5 * np.sin(x / 7)], axis=-1)
    disc = ((x - 30) ** 2 + (y - 22) ** 2) < 120
    a[disc] = [0.9, 0.4, 0.1]
    b = np.roll(a, 3, axis=1) * np.array([0.95, 1.0, 1.05], dtype=np.float32)
    to8 = lambda im: (np.clip(im, 0, 1) * 255).round().astype(np.uint8)
    return to8(a), to8(b)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--alexnet", help="torchvision's alexnet-owt-7be5be79.pth")
    source.add_argument("--tiny", type=int, help="seed of a tiny random test model")
    p.add_argument("--out", required=True)
    p.add_argument("--fixture", help="folder for the test images and PyTorch's distances")
    args = p.parse_args()

    model, backbone = lpips_model(args)
    wrapped = Distance(model).eval()
    example = torch.zeros(1, 3, 64, 64)
    torch.onnx.export(
        wrapped,
        (example, example),
        args.out,
        input_names=["a", "b"],
        output_names=["distance"],
        dynamic_axes={"a": {2: "height", 3: "width"}, "b": {2: "height", 3: "width"}},
        opset_version=17,
    )
    import onnx

    m = onnx.load(args.out)
    for key, value in {
        "role": "lpips",
        "lpips_version": "0.1",
        "backbone": backbone,
        "input_range": "[-1, 1]",
    }.items():
        entry = m.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.save(m, args.out)
    print(f"wrote {args.out} ({backbone})")

    if args.fixture:
        from PIL import Image
        import onnxruntime as ort

        os.makedirs(args.fixture, exist_ok=True)
        a8, b8 = fixture_images()
        Image.fromarray(a8).save(os.path.join(args.fixture, "a.png"))
        Image.fromarray(b8).save(os.path.join(args.fixture, "b.png"))
        tensor = lambda im: torch.from_numpy(im.astype(np.float32) / 127.5 - 1.0).permute(2, 0, 1)[None]
        with torch.no_grad():
            ab = float(wrapped(tensor(a8), tensor(b8)).flatten()[0])
            aa = float(wrapped(tensor(a8), tensor(a8)).flatten()[0])
        session = ort.InferenceSession(args.out, providers=["CPUExecutionProvider"])
        onnx_ab = float(session.run(None, {"a": tensor(a8).numpy(), "b": tensor(b8).numpy()})[0].flatten()[0])
        print(f"PyTorch: d(a, b) = {ab:.7f}, d(a, a) = {aa:.7f}; ONNX Runtime (Python): d(a, b) = {onnx_ab:.7f}")
        with open(os.path.join(args.fixture, "expected.json"), "w") as f:
            json.dump({"a_b": ab, "a_a": aa, "model": os.path.basename(args.out), "backbone": backbone}, f, indent=1)


if __name__ == "__main__":
    main()
