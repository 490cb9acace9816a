"""Parity check: the spec-written PyTorch networks in `hf2vad_reference.py` against the outputs of
the official HF²-VAD classes stored in `shared/parity/` (small configurations, README §2).

Usage:
    /work/torchenv/bin/python benches/pytorch_anchor/parity_check.py [--parity-dir /work/shared/parity] [--json out.json]

Exit status 0 iff every check passes. Tolerance per tensor (parity README §6):
    max|ours − ref| ≤ 1e-4 · max|ref| + 1e-9
which is ≈ 1e-4 absolute for the order-1 tensors (vadscope's A.9 rule), relative for the large
ones (S_r ≈ 3.3e4, KL ≈ 200) and tighter for tiny ones (gradients, of_recon). The max abs error of
every tensor is printed, and whether it is also ≤ 1e-4 absolute. In addition, the set of
attention entries that hard shrinkage zeroes must match exactly.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import sys

sys.dont_write_bytecode = True  # keep the repository free of __pycache__
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402
import torch  # noqa: E402
import torch.nn.functional as F  # noqa: E402
from safetensors.torch import load_file  # noqa: E402

import hf2vad_reference as R  # noqa: E402

REL_TOL = 1e-4
ABS_FLOOR = 1e-9


class Checker:
    def __init__(self):
        self.rows = []

    def check(self, name, ours, ref):
        ours = torch.as_tensor(ours).detach().to(torch.float64).reshape(-1)
        ref = torch.as_tensor(ref).detach().to(torch.float64).reshape(-1)
        if ours.shape != ref.shape:
            self.rows.append(dict(name=name, ok=False, note=f"shape {tuple(ours.shape)} vs {tuple(ref.shape)}"))
            return
        err = (ours - ref).abs().max().item()
        mref = ref.abs().max().item()
        tol = REL_TOL * mref + ABS_FLOOR
        self.rows.append(dict(name=name, ok=err <= tol, max_abs_err=err, max_abs_ref=mref, tol=tol,
                              abs_le_1e4=err <= 1e-4))

    def check_exact(self, name, ok, note=""):
        self.rows.append(dict(name=name, ok=bool(ok), note=note))

    def report(self):
        print(f"{'tensor':44s} {'max|err|':>11s} {'max|ref|':>11s} {'tol':>10s} {'≤1e-4':>6s}  result")
        for r in self.rows:
            if "max_abs_err" in r:
                print(f"{r['name']:44s} {r['max_abs_err']:11.3e} {r['max_abs_ref']:11.3e} {r['tol']:10.2e} "
                      f"{'yes' if r['abs_le_1e4'] else 'no':>6s}  {'ok' if r['ok'] else 'FAIL'}")
            else:
                print(f"{r['name']:44s} {'':11s} {'':11s} {'':10s} {'':6s}  {'ok' if r['ok'] else 'FAIL'} {r.get('note', '')}")
        n_fail = sum(not r["ok"] for r in self.rows)
        print(f"\n{len(self.rows) - n_fail}/{len(self.rows)} checks passed")
        return n_fail == 0


def entropy_sum(atts):
    """Σ over memories of mean over rows of −Σ_slots w·log(w + 1e-12)."""
    return sum((-(w * torch.log(w + 1e-12)).sum(dim=1)).mean() for w in atts)


def kl_loss(q_means, p_means):
    """Per scale 0.5·Σ_{C,H,W}(μq − μp)², batch mean, summed over scales. Returns (total, parts)."""
    parts = {}
    for key in q_means:
        d = q_means[key] - p_means[key]
        parts[key] = (0.5 * (d * d).flatten(1).sum(dim=1)).mean()
    return sum(parts.values()), parts


def intensity_loss(pred, target):
    return torch.mean(torch.abs(pred - target) ** 2)


def gradient_loss(pred, target, alpha=1):
    """[−1, 1] differences in x and y of the channel-summed image, zero-padded left/top."""
    c = pred.shape[1]
    wx = torch.tensor([-1.0, 1.0], dtype=pred.dtype).reshape(1, 1, 1, 2).repeat(1, c, 1, 1)
    wy = torch.tensor([-1.0, 1.0], dtype=pred.dtype).reshape(1, 1, 2, 1).repeat(1, c, 1, 1)

    def grads(x):
        gx = F.conv2d(F.pad(x, (1, 0, 0, 0)), wx)
        gy = F.conv2d(F.pad(x, (0, 0, 1, 0)), wy)
        return gx, gy

    pgx, pgy = grads(pred)
    tgx, tgy = grads(target)
    return torch.mean(torch.abs(tgx - pgx) ** alpha + torch.abs(tgy - pgy) ** alpha)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--parity-dir", default="/work/shared/parity")
    ap.add_argument("--json", default=None, help="also write the per-tensor results here")
    args = ap.parse_args()

    torch.set_num_threads(1)
    torch.set_num_interop_threads(1)
    d = args.parity_dir
    io = load_file(os.path.join(d, "hf2vad_io.safetensors"))
    ck = Checker()

    # ---- weights: official-layout checkpoint, strict -------------------------------------
    model = R.build_hfvad(R.PARITY_MEMAE, R.PARITY_VUNET)
    sd = torch.load(os.path.join(d, "hf2vad_official_layout.pth"), map_location="cpu", weights_only=True)
    res = model.load_state_dict(sd["model_state_dict"], strict=True)
    ck.check_exact("load_state_dict(official .pth, strict=True)", not res.missing_keys and not res.unexpected_keys,
                   f"{len(sd['model_state_dict'])} tensors")
    # The per-network safetensors hold the same values (bit-identical) and load strictly too.
    for make, fname, prefix in ((lambda: R.MLMemAESC(**R.PARITY_MEMAE), "memae.safetensors", "memAE."),
                                (lambda: R.VUNet(**R.PARITY_VUNET), "vunet.safetensors", "vunet.")):
        st = load_file(os.path.join(d, fname))
        same = all(torch.equal(st[k], sd["model_state_dict"][prefix + k]) for k in st)
        r2 = make().load_state_dict(st, strict=True)
        ck.check_exact(f"{fname} strict load, == .pth values", same and not r2.missing_keys and not r2.unexpected_keys,
                       f"{len(st)} tensors")
    model.eval()

    frames = io["input.frames_u8"].to(torch.float32) / 255.0
    flows = io["input.flows"]
    B = flows.shape[0]

    # ---- ML-MemAE-SC alone, eval, last flow -------------------------------------------------
    with torch.no_grad():
        o = model.memAE(flows[:, 6:8], return_intermediates=True)
    inter = o["intermediates"]
    ck.check("memae.x3", inter["x3"], io["memae.x3"])
    ck.check("memae.up3_out", inter["up3_out"], io["memae.up3_out"])
    for k in (1, 2, 3):
        ck.check(f"memae.att_softmax{k}", inter[f"att_softmax{k}"], io[f"memae.att_softmax{k}"])
        ck.check(f"memae.att_weight{k}", o[f"att_weight{k}"], io[f"memae.att_weight{k}"])
        ck.check_exact(f"memae.att_weight{k} zero pattern",
                       torch.equal(o[f"att_weight{k}"] == 0, io[f"memae.att_weight{k}"] == 0),
                       f"{int((io[f'memae.att_weight{k}'] == 0).sum())} zeros")
    ck.check("memae recon == hf2vad.of_recon[:, 6:8]", o["recon"], io["hf2vad.of_recon"][:, 6:8])

    # ---- HF²-VAD test mode, ε = 0 -----------------------------------------------------------
    model.vunet.zc.latent_sample = lambda mean: mean  # README §4 patch
    with torch.no_grad():
        h = model(frames, flows, mode="test", return_intermediates=True)
    ck.check("hf2vad.of_recon", h["of_recon"], io["hf2vad.of_recon"])
    ck.check("hf2vad.frame_pred", h["frame_pred"], io["hf2vad.frame_pred"])
    for k in (1, 2, 3):
        att = h[f"att_weight{k}"].reshape(4, B, -1)  # flow-major [4 flow, B, slots]
        ck.check(f"hf2vad.att_weight{k}", att, io[f"hf2vad.att_weight{k}"])
        ck.check_exact(f"hf2vad.att_weight{k} zero pattern", torch.equal(att == 0, io[f"hf2vad.att_weight{k}"] == 0),
                       f"{int((io[f'hf2vad.att_weight{k}'] == 0).sum())} zeros")
    for s in ("4x4", "8x8"):
        key = s.replace("x", "by")
        ck.check(f"hf2vad.q_mean_{s}", h["q_means"][key], io[f"hf2vad.q_mean_{s}"])
        ck.check(f"hf2vad.p_mean_{s}", h["p_means"][key], io[f"hf2vad.p_mean_{s}"])
    ck.check("vunet.f_phi.s4_2", h["vunet"]["f_phi"]["s4_2"], io["vunet.f_phi.s4_2"])
    ck.check("vunet.e_theta.s4_2", h["vunet"]["e_theta"]["s4_2"], io["vunet.e_theta.s4_2"])
    ck.check("vunet.bottleneck_out", h["vunet"]["bottleneck_out"], io["vunet.bottleneck_out"])
    # S_r / S_p as the reference computes them: float32 numpy sums of MSELoss(reduction="none").
    e_r = F.mse_loss(h["of_recon"], h["of_target"], reduction="none").numpy()
    e_p = F.mse_loss(h["frame_pred"], h["frame_target"], reduction="none").numpy()
    s_r = np.sum(e_r, axis=(1, 2, 3))
    s_p = np.sum(e_p, axis=(1, 2, 3))
    ck.check("hf2vad.S_r", s_r, io["hf2vad.S_r"])
    ck.check("hf2vad.S_p", s_p, io["hf2vad.S_p"])

    # ---- stage-2 losses on the ε = 0 outputs -------------------------------------------------
    with torch.no_grad():
        kl, kl_parts = kl_loss(h["q_means"], h["p_means"])
        lf = intensity_loss(h["frame_pred"], h["frame_target"])
        lg = gradient_loss(h["frame_pred"], h["frame_target"])
    ck.check("s2.loss_kl_4x4", kl_parts["4by4"], io["s2.loss_kl_4x4"])
    ck.check("s2.loss_kl_8x8", kl_parts["8by8"], io["s2.loss_kl_8x8"])
    ck.check("s2.loss_kl", kl, io["s2.loss_kl"])
    ck.check("s2.loss_frame", lf, io["s2.loss_frame"])
    ck.check("s2.loss_grad", lg, io["s2.loss_grad"])
    ck.check("s2.loss_total", kl + lf + lg, io["s2.loss_total"])

    # ---- stage-2 train mode with injected ε (dropout off) ----------------------------------
    eps = {4: io["s2_eps.eps_4x4"], 8: io["s2_eps.eps_8x8"]}
    model.vunet.zc.latent_sample = lambda mean: mean + eps[mean.shape[-1]]
    with torch.no_grad():
        t = model(frames, flows, mode="train")
        kl_t, _ = kl_loss(t["q_means"], t["p_means"])
        lf_t = intensity_loss(t["frame_pred"], t["frame_target"])
        lg_t = gradient_loss(t["frame_pred"], t["frame_target"])
    ck.check("s2_eps.frame_pred", t["frame_pred"], io["s2_eps.frame_pred"])
    ck.check("s2_eps.p_mean_4x4", t["p_means"]["4by4"], io["s2_eps.p_mean_4x4"])
    ck.check("s2_eps q_mean_4x4 == hf2vad.q_mean_4x4", t["q_means"]["4by4"], io["hf2vad.q_mean_4x4"])
    ck.check("s2_eps.loss_kl", kl_t, io["s2_eps.loss_kl"])
    ck.check("s2_eps.loss_frame", lf_t, io["s2_eps.loss_frame"])
    ck.check("s2_eps.loss_grad", lg_t, io["s2_eps.loss_grad"])
    ck.check("s2_eps.loss_total", kl_t + lf_t + lg_t, io["s2_eps.loss_total"])
    model.vunet.zc.latent_sample = lambda mean: mean

    # ---- stage-3 (finetune) loss formulas ----------------------------------------------------
    with torch.no_grad():
        s3_recon = F.mse_loss(h["of_recon"], h["of_target"])
        s3_sparsity = entropy_sum([h["att_weight1"], h["att_weight2"], h["att_weight3"]])
    ck.check("s3.loss_recon", s3_recon, io["s3.loss_recon"])
    ck.check("s3.loss_sparsity", s3_sparsity, io["s3.loss_sparsity"])

    # ---- stage 1: ML-MemAE-SC loss + backward, train and eval mode, fresh copies -------------
    grad_params = ["in_conv.conv.conv.0.weight", "in_conv.conv.conv.1.weight", "in_conv.conv.conv.1.bias",
                   "up_1.up.weight", "out_conv.conv.weight", "out_conv.conv.bias"]
    x_last = flows[:, 6:8]
    for mode in ("train", "eval"):
        m = copy.deepcopy(model.memAE)
        m.train(mode == "train")
        x = x_last.clone().requires_grad_(mode == "train")
        o = m(x)
        l_recon = F.mse_loss(o["recon"], x_last)  # target detached
        l_ent = entropy_sum([o["att_weight1"], o["att_weight2"], o["att_weight3"]])
        l_total = 1.0 * l_recon + 0.0002 * l_ent
        m.zero_grad()
        l_total.backward()
        p = f"s1_{mode}"
        ck.check(f"{p}.loss_recon", l_recon, io[f"{p}.loss_recon"])
        ck.check(f"{p}.loss_entropy", l_ent, io[f"{p}.loss_entropy"])
        ck.check(f"{p}.loss_total", l_total, io[f"{p}.loss_total"])
        named = dict(m.named_parameters())
        for gp in grad_params:
            ck.check(f"{p}.grad.{gp}", named[gp].grad, io[f"{p}.grad.{gp}"])
        if mode == "train":
            ck.check(f"{p}.recon", o["recon"], io[f"{p}.recon"])
            for k in (1, 2, 3):
                ck.check(f"{p}.att_weight{k}", o[f"att_weight{k}"], io[f"{p}.att_weight{k}"])
            ck.check(f"{p}.grad.input", x.grad, io[f"{p}.grad.input"])
            bn = m.in_conv.conv.conv[1]
            ck.check(f"{p}.bn_after...running_mean", bn.running_mean, io[f"{p}.bn_after.in_conv.conv.conv.1.running_mean"])
            ck.check(f"{p}.bn_after...running_var", bn.running_var, io[f"{p}.bn_after.in_conv.conv.conv.1.running_var"])

    print(f"torch {torch.__version__}, parity dir {d}, {len(io)} stored I/O tensors\n")
    ok = ck.report()
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"torch": torch.__version__, "all_ok": ok, "checks": ck.rows}, f, indent=1)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
