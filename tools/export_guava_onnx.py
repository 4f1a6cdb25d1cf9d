"""GUAVA mode's networks as four ONNX models, built from the authors' code (Apache-2.0).

    guava_encoder.onnx         image [1,3,S,S] in [0,1] (S = 518)
                               -> pixel_features [1,3+F,R,R]  (the image resized to R ‖ f_map1)
                                  vertex_features [1,P,R,R]   (f_map2, sampled at projected vertices)
                                  vertex_global [1,G]         (global_feature_mapping(f_global))
                                  uv_style [1,E]              (uv_style_mapping(f_global))
    guava_vertex_decoder.onnx  sampled [1,N,P], vertex_global [1,G], cam_dir [1,3]
                               -> colors [1,N,C], opacities [1,N,1], scales [1,N,3], rotations [1,N,4]
    guava_uv_decoder.onnx      uv_features [1,3+F,U,U], uv_style [1,E], cam_dir [1,3]
                               -> colors [1,U,U,C], opacities, scales, rotations, local_pos
    guava_refiner.onnx         splat [1,C,R,R] (the splatting pass's C channels on black)
                               -> rgb [1,3,R,R] in [0,1] (GaussianRenderer's StyleUNet refiner)

The split follows where the Rust side has to work between the networks (models/UbodyAvatar/
ubody_gaussian.py, Ubody_Gaussian_inferer.forward): projecting the posed body to sample
`vertex_features` at each vertex, and inverse texture mapping `pixel_features` into UV space with
face visibility. Learned constants ride inside the models (vertex_base_feature in the vertex
decoder, uv_base_feature in the UV decoder), and so does the camera-direction harmonic embedding;
`cam_dir` is the camera's z axis in world coordinates (get_cam_dirs: the third column of the
world-to-camera rotation). The two StyleUNets' noise inputs are zero: the reference draws fresh
noise every call, which no two runs (and no parity test) can share; zero is its mean.

Two sources of weights:

    --checkpoint CKPT   the official checkpoint (torch.load(CKPT)['model'], the inferer's state
                        dict; DINOv2 ViT-B/14 weights are inside it under dino_encoder.dino_model;
                        ['render_model'], the renderer's, holds the refiner under nerual_refiner.)
    --random SEED       randomly initialised networks with reduced widths (--reduced, the test
                        fixture: small files; the architecture is the reference's, only channel
                        counts and sizes shrink)

`--fixture FILE.npz` also saves random inputs and PyTorch's outputs for each model, which
tests/guava_onnx.rs matches through ONNX Runtime. What the tests ship was made with

    python tools/export_guava_onnx.py --guava ../shared/reference/GUAVA --random 0 --reduced \
        --out tests/data/guava_onnx --fixture tests/data/guava_onnx/fixture.npz

Needs PyTorch (CPU; 2.5.1 used), torchvision, lightning, onnx, onnxruntime, numpy; not CI.
DINOv2's own code is not installable offline (torch.hub), so the ViT below is written from its
published architecture (patch embedding, class token, learned positions at the native grid,
pre-norm blocks with LayerScale, final LayerNorm; get_intermediate_layers(x, 5) with norm=True
and the class token dropped) with DINOv2's parameter names, so the checkpoint's keys load as they are.
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference_env  # noqa: E402

FORMAT = "1"
FILES = {
    "encoder": "guava_encoder.onnx",
    "vertex_decoder": "guava_vertex_decoder.onnx",
    "uv_decoder": "guava_uv_decoder.onnx",
    "refiner": "guava_refiner.onnx",
}

# GUAVA's configuration (configs/train/ubody_512.yaml, ubody_gaussian.py) and the reduced one.
FULL = dict(image=518, render=512, uv=512, vit_dim=768, vit_depth=12, vit_heads=12,
            dino_out=32, prj_out=128, smplx_fea=128, global_dim=256, style=512, style_feat=512,
            style_mlp=8, channel_scale=1, uv_out=96, color=32, vertices=10595,
            head_dims=[256, 512, 1024, 1024])
# Reduced: small widths and sizes, but the synthetic EHM's 10,595 vertices, so the reduced models
# also run the whole GUAVA-mode reconstruction in the tests (tests/guava_mode.rs).
REDUCED = dict(image=56, render=32, uv=32, vit_dim=48, vit_depth=5, vit_heads=4,
               dino_out=32, prj_out=8, smplx_fea=8, global_dim=16, style=32, style_feat=32,
               style_mlp=2, channel_scale=8, uv_out=24, color=8, vertices=10595,
               head_dims=[16, 32, 64, 64])


def build(cfg, guava):
    import torch
    import torch.nn as nn

    reference_env.import_guava(guava)
    from models.modules.net_module import dino_encoder as dino_module
    from models.modules.net_module.feature_decoder import UV_Point_GS_Decoder, Vertex_GS_Decoder
    from models.modules.net_module.styleunet.styleunet import StyleUNet

    class Block(nn.Module):
        def __init__(self, dim, heads):
            super().__init__()
            self.norm1, self.norm2 = nn.LayerNorm(dim, eps=1e-6), nn.LayerNorm(dim, eps=1e-6)
            self.attn = nn.Module()
            self.attn.qkv, self.attn.proj = nn.Linear(dim, 3 * dim), nn.Linear(dim, dim)
            self.mlp = nn.Module()
            self.mlp.fc1, self.mlp.fc2 = nn.Linear(dim, 4 * dim), nn.Linear(4 * dim, dim)
            self.ls1, self.ls2 = nn.Module(), nn.Module()
            self.ls1.gamma = nn.Parameter(torch.ones(dim))
            self.ls2.gamma = nn.Parameter(torch.ones(dim))
            self.heads = heads

        def forward(self, x):
            b, n, d = x.shape
            qkv = self.attn.qkv(self.norm1(x)).reshape(b, n, 3, self.heads, d // self.heads)
            q, k, v = qkv.permute(2, 0, 3, 1, 4)
            a = ((q * (d // self.heads) ** -0.5) @ k.transpose(-2, -1)).softmax(dim=-1)
            x = x + self.ls1.gamma * self.attn.proj((a @ v).transpose(1, 2).reshape(b, n, d))
            h = self.mlp.fc2(nn.functional.gelu(self.mlp.fc1(self.norm2(x))))
            return x + self.ls2.gamma * h

    class DinoV2(nn.Module):
        def __init__(self, dim, depth, heads, grid):
            super().__init__()
            self.patch_embed = nn.Module()
            self.patch_embed.proj = nn.Conv2d(3, dim, 14, 14)
            self.cls_token = nn.Parameter(torch.randn(1, 1, dim) * 0.02)
            self.pos_embed = nn.Parameter(torch.randn(1, 1 + grid * grid, dim) * 0.02)
            self.mask_token = nn.Parameter(torch.zeros(1, dim))
            self.blocks = nn.ModuleList(Block(dim, heads) for _ in range(depth))
            self.norm = nn.LayerNorm(dim, eps=1e-6)

        def get_intermediate_layers(self, x, n):
            x = self.patch_embed.proj(x).flatten(2).transpose(1, 2)
            x = torch.cat([self.cls_token.expand(x.shape[0], -1, -1), x], dim=1) + self.pos_embed
            outputs = []
            for i, block in enumerate(self.blocks):
                x = block(x)
                if i >= len(self.blocks) - n:
                    outputs.append(self.norm(x)[:, 1:])
            return outputs

    grid = cfg["image"] // 14
    vit = DinoV2(cfg["vit_dim"], cfg["vit_depth"], cfg["vit_heads"], grid)
    torch.hub.load = lambda *args, **kwargs: vit  # DINO_Enocder fetches its backbone here
    dino = dino_module.DINO_Enocder(output_dim=cfg["dino_out"], output_dim_2=cfg["prj_out"],
                                    hidden_dims=cfg["prj_out"] // 2)
    if cfg["head_dims"] != FULL["head_dims"]:
        reduce_dino_head(dino, cfg["vit_dim"], cfg["head_dims"], cfg["prj_out"] // 2)

    def mlp(dim_in, dim):  # ubody_gaussian.py:40 and :56
        return nn.Sequential(nn.Linear(dim_in, dim), nn.LeakyReLU(inplace=True),
                             nn.Linear(dim, dim), nn.LeakyReLU(inplace=True), nn.Linear(dim, dim))

    net = nn.Module()  # attribute names are the inferer's, so its state dict loads into this
    net.dino_encoder = dino
    net.global_feature_mapping = mlp(cfg["vit_dim"], cfg["global_dim"])
    net.uv_style_mapping = mlp(cfg["vit_dim"], cfg["style"])
    net.vertex_gs_decoder = Vertex_GS_Decoder(
        in_dim=cfg["prj_out"] + cfg["smplx_fea"] + cfg["global_dim"], dir_dim=27,
        color_out_dim=cfg["color"])
    net.vertex_base_feature = nn.Parameter(torch.randn(cfg["vertices"], cfg["smplx_fea"]))
    net.uv_feature_decoder = StyleUNet(
        in_size=cfg["uv"], out_size=cfg["uv"], activation=False, in_dim=cfg["dino_out"] + 3,
        out_dim=cfg["uv_out"], extra_style_dim=cfg["style"], num_style_feat=cfg["style_feat"],
        num_mlp=cfg["style_mlp"], channel_scale=cfg["channel_scale"])
    net.uv_base_feature = nn.Parameter(torch.randn(32, cfg["uv"], cfg["uv"]))
    net.uv_point_decoder = UV_Point_GS_Decoder(in_dim=cfg["uv_out"] + 32, dir_dim=27,
                                               color_out_dim=cfg["color"])
    # GaussianRenderer's refiner (assets/GUAVA/config.yaml, styleunet: small, sigmoid output). Not
    # part of the inferer; built last so the other networks' random weights stay as they were.
    net.refiner = StyleUNet(
        in_size=cfg["render"], out_size=cfg["render"], in_dim=cfg["color"], out_dim=3,
        num_style_feat=cfg["style_feat"], num_mlp=cfg["style_mlp"],
        channel_scale=cfg["channel_scale"], small=True)
    zero_noise(net)
    return net


def zero_noise(net):
    """Both StyleUNets' noise as zeros (the mean of the noise the reference draws per call). The
    small generator (the refiner's) runs one noisy convolution per level, but its stored buffers
    are sized for two (level i gets 2**((i + 5) // 2) instead of 2**(i + 2)), so the reference's
    randomize_noise=False fails there: its buffers are replaced by zeros of the sizes it uses."""
    import torch

    for unet, small in ((net.uv_feature_decoder, False), (net.refiner, True)):
        g = unet.stylegan_decoder
        for i in range(g.num_layers):
            side = getattr(g.noises, f"noise{i}").shape[-1]
            if small and i <= g.log_size - 2:
                side = 2 ** (i + 2)
            g.noises.register_buffer(f"noise{i}", torch.zeros(1, 1, side, side))


def check_vit(vit, cfg):
    """Our ViT against Hugging Face's independent port of DINOv2 (`transformers.Dinov2Model`)
    with the same weights: the last five blocks' outputs after the final LayerNorm, patch tokens.
    LayerScale and LayerNorm parameters are randomised first so every parameter matters."""
    import torch
    from transformers import Dinov2Config, Dinov2Model

    with torch.no_grad():
        for name, p in vit.named_parameters():
            if "gamma" in name or "norm" in name:
                p.copy_(torch.randn_like(p) * 0.5 + (1.0 if name.endswith(("gamma", "weight")) else 0.0))
    config = Dinov2Config(hidden_size=cfg["vit_dim"], num_hidden_layers=cfg["vit_depth"],
                          num_attention_heads=cfg["vit_heads"], mlp_ratio=4, patch_size=14,
                          image_size=cfg["image"], layerscale_value=1.0, layer_norm_eps=1e-6,
                          hidden_act="gelu", qkv_bias=True, use_swiglu_ffn=False)
    hf = Dinov2Model(config).eval()
    ours = dict(vit.named_parameters())
    mapped = {
        "embeddings.cls_token": ours["cls_token"], "embeddings.mask_token": ours["mask_token"],
        "embeddings.position_embeddings": ours["pos_embed"],
        "embeddings.patch_embeddings.projection.weight": ours["patch_embed.proj.weight"],
        "embeddings.patch_embeddings.projection.bias": ours["patch_embed.proj.bias"],
        "layernorm.weight": ours["norm.weight"], "layernorm.bias": ours["norm.bias"],
    }
    for i in range(cfg["vit_depth"]):
        b, h = f"blocks.{i}.", f"encoder.layer.{i}."
        q, k, v = ours[b + "attn.qkv.weight"].chunk(3)
        qb, kb, vb = ours[b + "attn.qkv.bias"].chunk(3)
        for part, (w, bias) in zip(["query", "key", "value"], [(q, qb), (k, kb), (v, vb)]):
            mapped[h + f"attention.attention.{part}.weight"] = w
            mapped[h + f"attention.attention.{part}.bias"] = bias
        for theirs, mine in [("attention.output.dense", "attn.proj"), ("norm1", "norm1"),
                             ("norm2", "norm2"), ("mlp.fc1", "mlp.fc1"), ("mlp.fc2", "mlp.fc2")]:
            mapped[h + theirs + ".weight"] = ours[b + mine + ".weight"]
            mapped[h + theirs + ".bias"] = ours[b + mine + ".bias"]
        mapped[h + "layer_scale1.lambda1"] = ours[b + "ls1.gamma"]
        mapped[h + "layer_scale2.lambda1"] = ours[b + "ls2.gamma"]
    missing = set(hf.state_dict()) - set(mapped)
    assert not missing, f"unmapped Hugging Face parameters: {sorted(missing)}"
    hf.load_state_dict({k: v.detach().reshape(hf.state_dict()[k].shape) for k, v in mapped.items()})
    image = torch.rand(1, 3, cfg["image"], cfg["image"], generator=torch.Generator().manual_seed(5))
    with torch.no_grad():
        mine = vit.get_intermediate_layers(image, 5)
        hidden = hf(image, output_hidden_states=True).hidden_states
        theirs = [hf.layernorm(x)[:, 1:] for x in hidden[-5:]]
    worst = max((a - b).abs().max().item() / b.abs().max().item() for a, b in zip(mine, theirs))
    print(f"ViT vs transformers.Dinov2Model: max relative difference {worst:.2e} over 5 blocks")
    assert worst < 1e-5, "our ViT is not DINOv2's"


def reduce_dino_head(dino, vit_dim, dims, hidden):
    """The DPT head of DINO_Enocder with its hard-coded (256, 512, 1024, 1024) widths replaced:
    the same layers (dino_encoder.py:21-39), fewer channels."""
    import torch.nn as nn

    dino.projects = nn.ModuleList(nn.Conv2d(vit_dim, d, 1) for d in dims)
    dino.resize_layers = nn.ModuleList([
        nn.ConvTranspose2d(dims[0], dims[0], 4, 4), nn.ConvTranspose2d(dims[1], dims[1], 2, 2),
        nn.Identity(), nn.Conv2d(dims[3], dims[3], 3, 2, 1)])
    dino.layer_rn = nn.ModuleList(nn.Conv2d(d + 3, hidden, 3, 1, 1, bias=False) for d in dims)


def wrappers(net, cfg):
    import torch
    import torch.nn as nn

    harmonic = reference_env.harmonic_embedding(4)

    class Encoder(nn.Module):
        def __init__(self):
            super().__init__()
            self.net = net

        def forward(self, image):
            d = self.net.dino_encoder(image, output_size=cfg["render"])
            rgb = nn.functional.interpolate(image, (cfg["render"], cfg["render"]),
                                            mode="bilinear", align_corners=False)
            return (torch.cat([rgb, d["f_map1"]], dim=1), d["f_map2"],
                    self.net.global_feature_mapping(d["f_global"]),
                    self.net.uv_style_mapping(d["f_global"]))

    class VertexDecoder(nn.Module):
        def __init__(self):
            super().__init__()
            self.net = net

        def forward(self, sampled, vertex_global, cam_dir):
            n = sampled.shape[1]
            features = torch.cat([sampled, self.net.vertex_base_feature[None],
                                  vertex_global[:, None].expand(-1, n, -1)], dim=-1)
            d = self.net.vertex_gs_decoder(features, harmonic(cam_dir))
            return d["colors"], d["opacities"], d["scales"], d["rotations"]

    class UvDecoder(nn.Module):
        def __init__(self):
            super().__init__()
            self.net = net

        def forward(self, uv_features, uv_style, cam_dir):
            x = self.net.uv_feature_decoder(uv_features, randomize_noise=False,
                                            extra_style=uv_style)
            x = torch.cat([x, self.net.uv_base_feature[None]], dim=1)
            d = self.net.uv_point_decoder(x, harmonic(cam_dir))
            return d["colors"], d["opacities"], d["scales"], d["rotations"], d["local_pos"]

    class Refiner(nn.Module):
        def __init__(self):
            super().__init__()
            self.net = net

        def forward(self, splat):
            return self.net.refiner(splat, randomize_noise=False)

    s, r, u = cfg["image"], cfg["render"], cfg["uv"]
    gen = torch.Generator().manual_seed(1)
    cam = torch.tensor([[0.3, -0.2, 0.9]])
    cam = cam / cam.norm()
    uv_mask = (torch.rand(1, 1, u, u, generator=gen) > 0.3).float()  # invisible texels are zero
    return {
        "encoder": (Encoder(), {"image": torch.rand(1, 3, s, s, generator=gen)},
                    ["pixel_features", "vertex_features", "vertex_global", "uv_style"]),
        "vertex_decoder": (VertexDecoder(), {
            "sampled": torch.randn(1, cfg["vertices"], cfg["prj_out"], generator=gen),
            "vertex_global": torch.randn(1, cfg["global_dim"], generator=gen),
            "cam_dir": cam}, ["colors", "opacities", "scales", "rotations"]),
        "uv_decoder": (UvDecoder(), {
            "uv_features": torch.randn(1, cfg["dino_out"] + 3, u, u, generator=gen) * uv_mask,
            "uv_style": torch.randn(1, cfg["style"], generator=gen),
            "cam_dir": cam}, ["colors", "opacities", "scales", "rotations", "local_pos"]),
        # A splat image: features where the avatar covers (alpha-weighted), black elsewhere.
        "refiner": (Refiner(), {
            "splat": torch.randn(1, cfg["color"], r, r, generator=gen)
            * (torch.rand(1, 1, r, r, generator=gen) > 0.4).float()}, ["rgb"]),
    }


def resize_as_matrices(resize):
    """A stand-in for torchvision's resize(antialias=True) (the DINO head's image pyramid), which
    ONNX cannot express: ONNX Resize's antialias filter is not PyTorch's (0.05 apart measured on
    56 -> 16). The input size is fixed, so the resize is two constant matrices, each row made by
    the original resize itself from a one-hot column; traced as two matmuls. Run the model once
    before tracing: the matrices are made then and are constants to the tracer."""
    import torch

    matrices = {}

    def matrix(n_in, n_out):
        if (n_in, n_out) not in matrices:
            # Width 4, not 1: PyTorch's antialiased kernel treats a one-pixel axis differently.
            basis = torch.eye(n_in).reshape(n_in, 1, n_in, 1).expand(-1, -1, -1, 4)
            resized = resize(basis.contiguous(), (n_out, 4), antialias=True)
            matrices[n_in, n_out] = resized[:, 0, :, 0].T
        return matrices[n_in, n_out]

    def stand_in(img, size, antialias=True):
        assert antialias, "only the antialiased resize is replaced"
        rows, cols = matrix(int(img.shape[-2]), int(size[0])), matrix(int(img.shape[-1]), int(size[1]))
        return torch.einsum("oh,bchw,pw->bcop", rows, img, cols)

    return stand_in


def export(model, inputs, outputs, path, role, source, cfg):
    import onnx
    import torch

    tmp = path.with_suffix(".tmp")
    torch.onnx.export(model, tuple(inputs.values()), str(tmp), input_names=list(inputs),
                      output_names=outputs, opset_version=18, do_constant_folding=True)
    proto = onnx.load(str(tmp))
    for key, value in {"guava_rs.format": FORMAT, "guava_rs.role": role,
                       "guava_rs.source": source, "guava_rs.config": json.dumps(cfg)}.items():
        entry = proto.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.save(proto, str(tmp))
    tmp.replace(path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--guava", required=True, help="the GUAVA repository")
    weights = parser.add_mutually_exclusive_group(required=True)
    weights.add_argument("--checkpoint", help="GUAVA's checkpoint (its 'model' state dict)")
    weights.add_argument("--random", type=int, metavar="SEED", help="random weights")
    parser.add_argument("--reduced", action="store_true", help="reduced widths (with --random)")
    parser.add_argument("--out", required=True, help="folder for the four .onnx files")
    parser.add_argument("--fixture", help="also save inputs and PyTorch outputs here (.npz)")
    parser.add_argument("--only", choices=list(FILES), action="append",
                        help="export only this model (repeatable), e.g. GUAVA's full-size "
                             "refiner with random weights for `guava bench refiner`")
    parser.add_argument("--check-vit", action="store_true",
                        help="only check our DINOv2 ViT against transformers.Dinov2Model, then exit")
    args = parser.parse_args()
    if args.reduced and args.checkpoint:
        parser.error("--reduced goes with --random (the checkpoint has GUAVA's widths)")

    import onnxruntime
    import torch
    import torchvision.transforms.functional as tvf

    torch.set_float32_matmul_precision("highest")
    cfg = REDUCED if args.reduced else FULL
    if args.random is not None:
        torch.manual_seed(args.random)
    net = build(cfg, args.guava).eval()
    if args.check_vit:
        check_vit(net.dino_encoder.dino_model, cfg)
        return
    if args.checkpoint:
        checkpoint = torch.load(args.checkpoint, map_location="cpu", weights_only=False)
        state = checkpoint["model"]
        wanted = {k for k in net.state_dict() if not k.startswith("refiner.")}
        found = {k: v for k, v in state.items() if k in wanted}
        missing = sorted(set(wanted) - set(found))
        if missing:
            sys.exit(f"{args.checkpoint}: the 'model' state dict lacks {len(missing)} of the "
                     f"networks' parameters, first {missing[:5]}")
        net.load_state_dict(found, strict=False)
        render = checkpoint.get("render_model", {})
        prefix = "nerual_refiner."  # sic, the reference's spelling
        noise = "stylegan_decoder.noises."  # replaced by zeros below
        refiner = {k[len(prefix):]: v for k, v in render.items()
                   if k.startswith(prefix) and not k.startswith(prefix + noise)}
        missing = sorted(k for k in net.refiner.state_dict()
                         if k not in refiner and not k.startswith(noise))
        if missing:
            sys.exit(f"{args.checkpoint}: the 'render_model' state dict lacks {len(missing)} of "
                     f"the refiner's parameters, first {missing[:5]}")
        net.refiner.load_state_dict(refiner, strict=False)
        zero_noise(net)  # the checkpoint's stored noise buffers loaded above are not used
        source = f"checkpoint {Path(args.checkpoint).name}"
    else:
        source = f"random weights, seed {args.random}" + (", reduced widths" if args.reduced else "")

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fixture = {}
    original_resize = tvf.resize
    for role, (model, inputs, names) in wrappers(net, cfg).items():
        if args.only and role not in args.only:
            continue
        path = out / FILES[role]
        with torch.no_grad():
            expected = model(**inputs)  # the reference's own resize
        tvf.resize = resize_as_matrices(original_resize)
        with torch.no_grad():
            model(**inputs)
        export(model, inputs, names, path, role, source, cfg)
        tvf.resize = original_resize
        session = onnxruntime.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        got = session.run(names, {k: v.numpy() for k, v in inputs.items()})
        for name, e, g in zip(names, expected, got):
            rel = np.abs(g - e.numpy()).max() / max(np.abs(e.numpy()).max(), 1e-12)
            print(f"{FILES[role]} {name} {tuple(g.shape)}: max |ORT - PyTorch| / max |PyTorch| "
                  f"= {rel:.2e}")
            fixture[f"{role}.out.{name}"] = e.numpy().astype(np.float32)
        for name, value in inputs.items():
            fixture[f"{role}.in.{name}"] = value.numpy().astype(np.float32)
        print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)")
    if args.fixture:
        np.savez_compressed(args.fixture, **fixture)
        print(f"wrote {args.fixture}")


if __name__ == "__main__":
    main()
