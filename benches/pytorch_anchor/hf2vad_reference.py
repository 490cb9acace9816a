"""HF²-VAD reference networks in PyTorch, written from vadscope's spec.

This module is an independent re-implementation of the two HF²-VAD networks and the combined
model, written from `shared/design/hf2vad-model.md` Part B (layer tables, formulas) and the
state-dict key map in `shared/parity/README.md` §7. No reference source code was used. Module
attribute names are chosen so that `state_dict()` keys equal the official ones, so the
official-layout checkpoint (`{"model_state_dict": HFVAD.state_dict()}`) loads with
`load_state_dict(strict=True)`.

`parity_check.py` proves these modules reproduce the outputs of the official classes.

Contents:
- `MLMemAESC`  ML-MemAE-SC: U-Net-like autoencoder, strided-conv downsampling, ConvTranspose
                upsampling, memory modules with hard shrinkage, skip ops none/concat/add.
- `VUNet`      the CVAE: weight-normalised convs with a learned affine, pre-activation ELU
                res-blocks, space-to-depth/depth-to-space (TensorFlow "DCR" channel order),
                sub-pixel upsampling, posterior ZConverter, autoregressive prior, sigmoid output.
- `HFVAD`      memAE on each of the 4 flows, then the CVAE predicts the target frame.
- `paper_*` / `parity_*` helpers that build the two configurations used in this folder.
"""

from __future__ import annotations

import math
import warnings

import torch
import torch.nn as nn
import torch.nn.functional as F

# `torch.nn.utils.weight_norm` gives exactly the official parameter names (`weight_g`,
# `weight_v`) and recomputes the weight in a forward pre-hook on every call, like the reference.
# It is deprecated (FutureWarning) but still present in torch 2.15.
warnings.filterwarnings("ignore", message=r".*torch\.nn\.utils\.weight_norm.*", category=FutureWarning)


# ---------------------------------------------------------------------------------------------
# ML-MemAE-SC (spec Part B §3)
# ---------------------------------------------------------------------------------------------


class DoubleConvBlock(nn.Module):
    """[Conv3x3 s1 p1 -> BN -> ReLU] x 2.  Keys: `conv.{0,1,3,4}`."""

    def __init__(self, in_ch: int, out_ch: int):
        super().__init__()
        self.conv = nn.Sequential(
            nn.Conv2d(in_ch, out_ch, 3, stride=1, padding=1, bias=True),
            nn.BatchNorm2d(out_ch),
            nn.ReLU(inplace=True),
            nn.Conv2d(out_ch, out_ch, 3, stride=1, padding=1, bias=True),
            nn.BatchNorm2d(out_ch),
            nn.ReLU(inplace=True),
        )

    def forward(self, x):
        return self.conv(x)


class InConv(nn.Module):
    """Keys: `conv.conv.*`."""

    def __init__(self, in_ch: int, out_ch: int):
        super().__init__()
        self.conv = DoubleConvBlock(in_ch, out_ch)

    def forward(self, x):
        return self.conv(x)


class Down(nn.Module):
    """Strided Conv3x3 s2 p1 (C -> 2C, no norm/activation), then double_conv.  Keys: `mpconv.{0,1}`."""

    def __init__(self, in_ch: int, out_ch: int):
        super().__init__()
        self.mpconv = nn.Sequential(
            nn.Conv2d(in_ch, out_ch, 3, stride=2, padding=1, bias=True),
            DoubleConvBlock(out_ch, out_ch),
        )

    def forward(self, x):
        return self.mpconv(x)


class Up(nn.Module):
    """ConvTranspose2d k3 s2 p1 op1, optional skip fusion, then double_conv.  Keys: `up`, `conv.conv.*`.

    op "concat": double_conv on concat[skip, up] (2*out -> out); "add": on skip + up;
    "none": on up only.
    """

    def __init__(self, in_ch: int, out_ch: int, op: str):
        super().__init__()
        if op not in ("none", "concat", "add"):
            raise ValueError(f"unknown skip op {op!r}")
        self.op = op
        self.up = nn.ConvTranspose2d(in_ch, out_ch, 3, stride=2, padding=1, output_padding=1)
        self.conv = DoubleConvBlock(2 * out_ch if op == "concat" else out_ch, out_ch)

    def forward(self, x, skip=None):
        x = self.up(x)
        if self.op == "concat":
            x = torch.cat([skip, x], dim=1)
        elif self.op == "add":
            x = skip + x
        return self.conv(x)


class OutConv(nn.Module):
    """1x1 conv, linear output.  Keys: `conv`."""

    def __init__(self, in_ch: int, out_ch: int):
        super().__init__()
        self.conv = nn.Conv2d(in_ch, out_ch, 1)

    def forward(self, x):
        return self.conv(x)


def hard_shrink_relu(w: torch.Tensor, lambd: float, eps: float = 1e-12) -> torch.Tensor:
    """ReLU(w - λ) · w / (|w - λ| + eps)."""
    return F.relu(w - lambd) * w / (torch.abs(w - lambd) + eps)


class Memory(nn.Module):
    """Memory of `num_slots` slots of dimension C·H·W (one query per sample).  Key: `memMatrix`.

    Read: softmax(q · Mᵀ) over slots -> hard shrinkage (if λ > 0) -> L1 renormalisation -> ŵ · M.
    """

    def __init__(self, num_slots: int, slot_dim: int, shrink_thres: float):
        super().__init__()
        self.num_slots = num_slots
        self.slot_dim = slot_dim
        self.shrink_thres = shrink_thres
        self.memMatrix = nn.Parameter(torch.empty(num_slots, slot_dim))
        self.reset_parameters()

    def reset_parameters(self):
        bound = 1.0 / math.sqrt(self.slot_dim)
        self.memMatrix.data.uniform_(-bound, bound)

    def attention_softmax(self, x: torch.Tensor) -> torch.Tensor:
        """Pre-shrinkage attention (used only by the parity check)."""
        return F.softmax(F.linear(x.reshape(x.shape[0], -1), self.memMatrix), dim=1)

    def forward(self, x: torch.Tensor):
        shape = x.shape
        q = x.reshape(shape[0], -1)  # row-major over [C, H, W]
        att = F.softmax(F.linear(q, self.memMatrix), dim=1)
        if self.shrink_thres > 0:
            att = hard_shrink_relu(att, self.shrink_thres)
            att = F.normalize(att, p=1, dim=1)
        out = F.linear(att, self.memMatrix.t())  # ŵ · M
        return out.reshape(shape), att


class MLMemAESC(nn.Module):
    """ML-MemAE-SC (spec B.3).

    mem_usage[k] / skip_ops[k] index the decoder levels from the top: level 0 is the full
    resolution (after up_1; mem_usage[0] has no module), level 1 is after up_2 (mem1), level 2
    after up_3 (mem2), level 3 the bottleneck x3 (mem3). skip_ops[0/1/2] belong to up_1/up_2/up_3.
    """

    def __init__(self, num_in_ch=2, seq_len=1, features_root=32, num_slots=2000,
                 shrink_thres=0.0005, mem_usage=(False, True, True, True),
                 skip_ops=("none", "concat", "concat"), spatial_size=32):
        super().__init__()
        self.num_in_ch = num_in_ch
        self.seq_len = seq_len
        self.num_slots = num_slots
        self.shrink_thres = shrink_thres
        self.mem_usage = list(mem_usage)
        self.skip_ops = list(skip_ops)
        fr = features_root
        s = spatial_size

        self.in_conv = InConv(num_in_ch * seq_len, fr)
        self.down_1 = Down(fr, fr * 2)
        self.down_2 = Down(fr * 2, fr * 4)
        self.down_3 = Down(fr * 4, fr * 8)
        if self.mem_usage[3]:
            self.mem3 = Memory(num_slots, fr * 8 * (s // 8) ** 2, shrink_thres)
        self.up_3 = Up(fr * 8, fr * 4, self.skip_ops[2])
        if self.mem_usage[2]:
            self.mem2 = Memory(num_slots, fr * 4 * (s // 4) ** 2, shrink_thres)
        self.up_2 = Up(fr * 4, fr * 2, self.skip_ops[1])
        if self.mem_usage[1]:
            self.mem1 = Memory(num_slots, fr * 2 * (s // 2) ** 2, shrink_thres)
        self.up_1 = Up(fr * 2, fr, self.skip_ops[0])
        self.out_conv = OutConv(fr, num_in_ch * seq_len)

    def forward(self, x, return_intermediates: bool = False):
        b = x.shape[0]
        x0 = self.in_conv(x)
        x1 = self.down_1(x0)
        x2 = self.down_2(x1)
        x3 = self.down_3(x2)
        inter = {"x3": x3}
        zeros = lambda: torch.zeros(b, self.num_slots, dtype=x.dtype, device=x.device)  # noqa: E731

        def through(level, h):
            # A disabled memory passes its input on with the reference's all-zero attention.
            if not self.mem_usage[level]:
                return h, zeros()
            memory = getattr(self, f"mem{level}")
            if return_intermediates:
                inter[f"att_softmax{level}"] = memory.attention_softmax(h)
            return memory(h)

        h, att3 = through(3, x3)
        h = self.up_3(h, x2)
        inter["up3_out"] = h
        h, att2 = through(2, h)
        h = self.up_2(h, x1)
        h, att1 = through(1, h)
        h = self.up_1(h, x0)
        recon = self.out_conv(h)
        out = {"recon": recon, "att_weight1": att1, "att_weight2": att2, "att_weight3": att3}
        if return_intermediates:
            out["intermediates"] = inter
        return out


def weights_init_kaiming(m: nn.Module):
    """Stage-1/2 training init (spec B.5). Not used for timing (default init is timed)."""
    if isinstance(m, (nn.Conv2d, nn.Linear)) and hasattr(m, "weight") and isinstance(m.weight, nn.Parameter):
        nn.init.kaiming_normal_(m.weight, a=0.1, mode="fan_in")
    elif isinstance(m, nn.BatchNorm2d):
        nn.init.normal_(m.weight, 1.0, 0.02)
        nn.init.zeros_(m.bias)


# ---------------------------------------------------------------------------------------------
# VUNet (spec Part B §4)
# ---------------------------------------------------------------------------------------------


def depth_to_space(x: torch.Tensor, block: int = 2) -> torch.Tensor:
    """TensorFlow "DCR" order: out[c, b*h+i, b*w+j] = in[(b*i+j)*C' + c, h, w]."""
    n, c, h, w = x.shape
    cp = c // (block * block)
    x = x.reshape(n, block, block, cp, h, w)          # [n, i, j, c', h, w]
    x = x.permute(0, 3, 4, 1, 5, 2)                   # [n, c', h, i, w, j]
    return x.reshape(n, cp, h * block, w * block)


def space_to_depth(x: torch.Tensor, block: int = 2) -> torch.Tensor:
    """Inverse of `depth_to_space`."""
    n, c, h, w = x.shape
    x = x.reshape(n, c, h // block, block, w // block, block)  # [n, c, h, i, w, j]
    x = x.permute(0, 3, 5, 1, 2, 4)                            # [n, i, j, c, h, w]
    return x.reshape(n, block * block * c, h // block, w // block)


class NormConv2d(nn.Module):
    """Weight-normalised conv followed by a learned per-channel affine: γ·conv(x) + β.

    Keys: `beta` [1,C,1,1], `gamma` [1,C,1,1], `conv.bias`, `conv.weight_g`, `conv.weight_v`.
    Effective weight = g · v / ‖v‖ (L2 per output channel over (Cin, k, k)).
    """

    def __init__(self, in_ch: int, out_ch: int, kernel_size: int, stride: int = 1, padding: int = 0):
        super().__init__()
        self.beta = nn.Parameter(torch.zeros(1, out_ch, 1, 1))
        self.gamma = nn.Parameter(torch.ones(1, out_ch, 1, 1))
        self.conv = nn.utils.weight_norm(
            nn.Conv2d(in_ch, out_ch, kernel_size, stride=stride, padding=padding, bias=True), dim=0)

    def forward(self, x):
        return self.gamma * self.conv(x) + self.beta


class ResBlock(nn.Module):
    """Pre-activation res-block: x + Conv3x3(Dropout(ELU(h))), h = x or concat[x, pre(ELU(skip))].

    Keys: `conv2d` (the 3x3 NormConv2d) and, with a skip, `pre` (1x1 NormConv2d).
    """

    def __init__(self, channels: int, use_skip: bool, dropout: float):
        super().__init__()
        self.use_skip = use_skip
        if use_skip:
            self.pre = NormConv2d(channels, channels, 1)
            self.conv2d = NormConv2d(2 * channels, channels, 3, padding=1)
        else:
            self.conv2d = NormConv2d(channels, channels, 3, padding=1)
        self.dropout = nn.Dropout(dropout)

    def forward(self, x, skip=None):
        h = x
        if self.use_skip:
            h = torch.cat([x, self.pre(F.elu(skip))], dim=1)
        h = F.elu(h)
        h = self.dropout(h)
        return x + self.conv2d(h)


class Downsample(nn.Module):
    """NormConv2d 3x3 s2 p1.  Keys: `down`."""

    def __init__(self, in_ch: int, out_ch: int):
        super().__init__()
        self.down = NormConv2d(in_ch, out_ch, 3, stride=2, padding=1)

    def forward(self, x):
        return self.down(x)


class Upsample(nn.Module):
    """Sub-pixel upsampling: NormConv2d 3x3 C_in -> 4·C_out, then depth-to-space ×2.  Keys: `up`."""

    def __init__(self, in_ch: int, out_ch: int):
        super().__init__()
        self.up = NormConv2d(in_ch, 4 * out_ch, 3, padding=1)

    def forward(self, x):
        return depth_to_space(self.up(x), 2)


class VUNetEncoder(nn.Module):
    """in_op 1x1, then per stage (2 res-blocks each, downsampling between stages)."""

    def __init__(self, in_ch: int, n_stages: int, nf_start: int, nf_max: int, dropout: float):
        super().__init__()
        self.n_stages = n_stages
        self.in_op = NormConv2d(in_ch, nf_start, 1)
        self.blocks = nn.ModuleDict()
        self.downs = nn.ModuleDict()
        nf = nf_start
        for i in range(n_stages):
            stage = i + 1
            if i > 0:
                nf_new = min(nf_max, nf * 2)
                self.downs[f"s{stage}"] = Downsample(nf, nf_new)
                nf = nf_new
            for k in (1, 2):
                self.blocks[f"s{stage}_{k}"] = ResBlock(nf, use_skip=False, dropout=dropout)
        self.out_channels = nf

    def forward(self, x):
        feats = {}
        h = self.in_op(x)
        for i in range(self.n_stages):
            stage = i + 1
            if i > 0:
                h = self.downs[f"s{stage}"](h)
            for k in (1, 2):
                h = self.blocks[f"s{stage}_{k}"](h)
                feats[f"s{stage}_{k}"] = h
        return feats


class ZConverter(nn.Module):
    """Posterior q(z | past frames, flows) at 4x4 and 8x8 (spec B.4.3)."""

    def __init__(self, n_stages: int, nf: int, dropout: float):
        super().__init__()
        self.n_stages = n_stages
        self.conv1x1 = NormConv2d(nf, nf, 1)
        self.blocks = nn.ModuleList([ResBlock(nf, use_skip=True, dropout=dropout) for _ in range(3)])
        self.channel_norm = NormConv2d(2 * nf, nf, 1)
        self.up = Upsample(nf, nf)
        # Test-mode sampling of z at 4x4, as the reference does (spec B.9.1). `latent_sample`
        # may be replaced (parity check: ε = 0 or injected ε).
        self.sample_test_4x4 = True
        self.latent_sample = lambda mean: mean + torch.randn_like(mean)

    def forward(self, f_feats, mode: str = "test"):
        n = self.n_stages
        s_last = f"s{n}_2"
        h = self.conv1x1(f_feats[s_last])
        # 4x4
        h = self.blocks[0](h, f_feats[s_last])
        q4 = h
        z4 = self.latent_sample(q4) if (mode == "train" or self.sample_test_4x4) else q4
        h = self.blocks[1](h, self.channel_norm(torch.cat([f_feats[f"s{n}_1"], z4], dim=1)))
        h = self.up(h)
        # 8x8
        h = self.blocks[2](h, f_feats[f"s{n - 1}_2"])
        q8 = h
        z8 = self.latent_sample(q8) if mode == "train" else q8
        return {"q_means": {f"{q4.shape[-1]}by{q4.shape[-1]}": q4, f"{q8.shape[-1]}by{q8.shape[-1]}": q8},
                "z": [z4, z8]}


class VUNetBottleneck(nn.Module):
    """Prior p(z | flows) with a 4-group autoregressive model, plus latent fusion (spec B.4.3)."""

    def __init__(self, n_stages: int, nf: int, dropout: float):
        super().__init__()
        self.n_stages = n_stages
        self.conv1x1 = NormConv2d(nf, nf, 1)
        self.blocks = nn.ModuleDict()
        self.channel_norm = nn.ModuleDict()
        for stage in (n_stages, n_stages - 1):
            self.blocks[f"s{stage}_2"] = ResBlock(nf, use_skip=True, dropout=dropout)
            self.blocks[f"s{stage}_1"] = ResBlock(nf, use_skip=True, dropout=dropout)
            self.channel_norm[f"s{stage}"] = NormConv2d(2 * nf, nf, 1)
        self.up = Upsample(nf, nf)
        self.auto_blocks = nn.ModuleList(
            [ResBlock(nf, use_skip=(i > 0), dropout=dropout) for i in range(4)])
        self.param_converter = NormConv2d(4 * nf, nf, 1)

    def prior_mean(self, h, z):
        a = self.auto_blocks[0](h)
        param = self.param_converter(space_to_depth(a))
        z_groups = torch.chunk(space_to_depth(z), 4, dim=1)
        params = [param]
        for g in range(1, 4):
            param = self.auto_blocks[g](param, z_groups[g - 1])
            params.append(param)
        return depth_to_space(torch.cat(params, dim=1))

    def forward(self, e_feats, zs):
        n = self.n_stages
        h = self.conv1x1(e_feats[f"s{n}_2"])
        p_means = {}
        for i, stage in enumerate((n, n - 1)):
            if i > 0:
                h = self.up(h)
            z = zs[i]
            h = self.blocks[f"s{stage}_2"](h, e_feats[f"s{stage}_2"])
            p = self.prior_mean(h, z)
            p_means[f"{p.shape[-1]}by{p.shape[-1]}"] = p
            h = self.blocks[f"s{stage}_1"](
                h, self.channel_norm[f"s{stage}"](torch.cat([e_feats[f"s{stage}_1"], z], dim=1)))
        return h, p_means


class VUNetDecoder(nn.Module):
    """Upsample from stage n-1 to stage 1 with f_phi skips, 1x1 conv to RGB, sigmoid."""

    def __init__(self, n_stages: int, nf_max: int, img_channels: int, dropout: float):
        super().__init__()
        self.n_stages = n_stages
        self.ups = nn.ModuleDict()
        self.blocks = nn.ModuleDict()
        nf = nf_max
        for stage in range(n_stages - 1, 1, -1):  # e.g. s3 (8->16), s2 (16->32) for 4 stages
            nf_out = nf_max // 2 if stage == 2 else nf_max
            self.ups[f"s{stage}"] = Upsample(nf, nf_out)
            nf = nf_out
            for k in (2, 1):
                self.blocks[f"s{stage - 1}_{k}"] = ResBlock(nf, use_skip=True, dropout=dropout)
        self.final_layer = NormConv2d(nf, img_channels, 1)

    def forward(self, h, f_feats):
        for stage in range(self.n_stages - 1, 1, -1):
            h = self.ups[f"s{stage}"](h)
            for k in (2, 1):
                key = f"s{stage - 1}_{k}"
                h = self.blocks[key](h, f_feats[key])
        return torch.sigmoid(self.final_layer(h))


class VUNet(nn.Module):
    """The CVAE (spec B.4). Input: 4 past frames (12 ch) and 4 reconstructed flows (8 ch)."""

    def __init__(self, spatial_size=32, nf_start=64, nf_max=128, dropout_prob=0.1, img_channels=3,
                 motion_channels=2, clip_hist=4, clip_pred=1, num_flows=4, final_act=False):
        super().__init__()
        if final_act:
            raise NotImplementedError("final_act=True (LeakyReLU / plain convs) is not part of the spec'd configs")
        n_stages = 1 + round(math.log2(spatial_size)) - 2
        self.n_stages = n_stages
        self.clip_hist = clip_hist
        frames_ch = img_channels * clip_hist
        flows_ch = motion_channels * num_flows
        self.f_phi = VUNetEncoder(frames_ch + flows_ch, n_stages, nf_start, nf_max, dropout_prob)
        self.e_theta = VUNetEncoder(flows_ch, n_stages, nf_start, nf_max, dropout_prob)
        nf = self.f_phi.out_channels
        self.zc = ZConverter(n_stages, nf, dropout_prob)
        self.bottleneck = VUNetBottleneck(n_stages, nf, dropout_prob)
        self.decoder = VUNetDecoder(n_stages, nf_max, img_channels * clip_pred, dropout_prob)

    def forward(self, frames_hist, of_recon, mode: str = "test", return_intermediates: bool = False):
        f_feats = self.f_phi(torch.cat([frames_hist, of_recon], dim=1))
        zc_out = self.zc(f_feats, mode=mode)
        q_means = zc_out["q_means"]
        zs = zc_out["z"] if mode == "train" else list(q_means.values())
        e_feats = self.e_theta(of_recon)
        h, p_means = self.bottleneck(e_feats, zs)
        frame_pred = self.decoder(h, f_feats)
        out = {"frame_pred": frame_pred, "q_means": q_means, "p_means": p_means}
        if return_intermediates:
            out["f_phi"] = f_feats
            out["e_theta"] = e_feats
            out["bottleneck_out"] = h
        return out


# ---------------------------------------------------------------------------------------------
# HF²-VAD
# ---------------------------------------------------------------------------------------------


class HFVAD(nn.Module):
    """ML-MemAE-SC on each of the `num_flows` flows (shared weights), then the CVAE.

    Inputs: frames [B, 3·(num_hist+num_pred), H, W] in [0, 1]; flows [B, 2·num_flows, H, W].
    """

    def __init__(self, memae: MLMemAESC, vunet: VUNet, num_hist: int = 4, num_pred: int = 1,
                 num_flows: int = 4, img_channels: int = 3, motion_channels: int = 2):
        super().__init__()
        self.memAE = memae
        self.vunet = vunet
        self.num_hist = num_hist
        self.num_pred = num_pred
        self.num_flows = num_flows
        self.img_channels = img_channels
        self.motion_channels = motion_channels

    def forward(self, frames, flows, mode: str = "test", return_intermediates: bool = False):
        mc = self.motion_channels
        recons, atts = [], {1: [], 2: [], 3: []}
        for j in range(self.num_flows):
            o = self.memAE(flows[:, j * mc:(j + 1) * mc])
            recons.append(o["recon"])
            for k in (1, 2, 3):
                atts[k].append(o[f"att_weight{k}"])
        of_recon = torch.cat(recons, dim=1)
        n_hist_ch = self.img_channels * self.num_hist
        v = self.vunet(frames[:, :n_hist_ch], of_recon, mode=mode, return_intermediates=return_intermediates)
        out = {
            "frame_pred": v["frame_pred"],
            "frame_target": frames[:, n_hist_ch:],
            "of_recon": of_recon,
            "of_target": flows,
            # flow-major concatenation along dim 0: [num_flows·B, slots]
            "att_weight1": torch.cat(atts[1], dim=0),
            "att_weight2": torch.cat(atts[2], dim=0),
            "att_weight3": torch.cat(atts[3], dim=0),
            "q_means": v["q_means"],
            "p_means": v["p_means"],
        }
        if return_intermediates:
            out["vunet"] = v
        return out


# ---------------------------------------------------------------------------------------------
# Configurations
# ---------------------------------------------------------------------------------------------

PAPER_MEMAE = dict(num_in_ch=2, seq_len=1, features_root=32, num_slots=2000, shrink_thres=0.0005,
                   mem_usage=(False, True, True, True), skip_ops=("none", "concat", "concat"))
PAPER_VUNET = dict(spatial_size=32, nf_start=64, nf_max=128, dropout_prob=0.1, img_channels=3,
                   motion_channels=2, clip_hist=4, clip_pred=1, num_flows=4, final_act=False)

# shared/parity/README.md §2
PARITY_MEMAE = dict(num_in_ch=2, seq_len=1, features_root=8, num_slots=16, shrink_thres=1.0 / 16,
                    mem_usage=(False, True, True, True), skip_ops=("none", "concat", "concat"))
PARITY_VUNET = dict(spatial_size=32, nf_start=16, nf_max=32, dropout_prob=0.1, img_channels=3,
                    motion_channels=2, clip_hist=4, clip_pred=1, num_flows=4, final_act=False)


def build_hfvad(memae_cfg: dict, vunet_cfg: dict) -> HFVAD:
    return HFVAD(MLMemAESC(**memae_cfg), VUNet(**vunet_cfg), num_hist=vunet_cfg["clip_hist"],
                 num_pred=vunet_cfg["clip_pred"], num_flows=vunet_cfg["num_flows"],
                 img_channels=vunet_cfg["img_channels"], motion_channels=vunet_cfg["motion_channels"])


def paper_memae() -> MLMemAESC:
    return MLMemAESC(**PAPER_MEMAE)


def paper_hfvad() -> HFVAD:
    return build_hfvad(PAPER_MEMAE, PAPER_VUNET)


def count_params(m: nn.Module) -> int:
    return sum(p.numel() for p in m.parameters() if p.requires_grad)


if __name__ == "__main__":
    torch.manual_seed(0)
    model = paper_hfvad()
    parts = {
        "memAE": model.memAE, "memAE memories": None, "vunet": model.vunet,
        "vunet.f_phi": model.vunet.f_phi, "vunet.e_theta": model.vunet.e_theta,
        "vunet.zc": model.vunet.zc, "vunet.bottleneck": model.vunet.bottleneck,
        "vunet.decoder": model.vunet.decoder, "HFVAD": model,
    }
    for name, m in parts.items():
        if m is None:
            n = sum(mm.memMatrix.numel() for mm in (model.memAE.mem1, model.memAE.mem2, model.memAE.mem3))
        else:
            n = count_params(m)
        print(f"{name:18s} {n:>12,d}")
