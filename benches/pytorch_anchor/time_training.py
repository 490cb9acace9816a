"""Time one PyTorch CPU optimiser step of each HF²-VAD training stage, the anchor for
`VADSCOPE_BENCH=train cargo bench --bench model`.

Steps, as `shared/design/pytorch-cpu-anchor.md` ("Stage-1/2 training step") defines them and
as the Rust benchmark runs them (same batch sizes, losses and optimiser):
- stage 1: ML-MemAE-SC in `train()` on the last flow [B, 2, 32, 32]; loss MSE + 0.0002 ·
  attention entropy; Adam(lr 1e-4, eps 1e-7). Batch 256.
- stage 2: ML-MemAE-SC frozen in `eval()`, the CVAE in `train()`, `mode="train"` (posterior
  sampled); loss KL + intensity + gradient; Adam(lr 1e-4, eps 1e-7) over the CVAE. Batch 128.
- stage 3: both networks in `train()`; loss stage 2's + flow MSE + 0.0002 · entropy;
  Adam(lr 8e-5, eps 1e-7) over both. Batch 128.

Configurations: `paper` (spec Part B) and `compact` (vadscope's bundled preset: features_root
16, 500 slots, λ 1/500, CVAE 32/64). Each (config, stage, threads) runs in a fresh worker
process with `torch.set_num_threads(N)` and `set_num_interop_threads(1)`; 2 warm-up steps,
then at least 3 timed steps and 10 s; median, min and max seconds per step are reported, with
the process's peak resident memory. No load guard: run it on a quiet machine, interleaved
with the Rust benchmark when comparing (this host's speed drifts by the hour).

Usage:
    /work/torchenv/bin/python benches/pytorch_anchor/time_training.py
        [--configs paper compact] [--stages 1 2 3] [--threads 1 2] [--out results.json]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time

sys.dont_write_bytecode = True  # keep the repository free of __pycache__
HERE = os.path.dirname(os.path.abspath(__file__))

BATCH = {1: 256, 2: 128, 3: 128}


def configs():
    from hf2vad_reference import PAPER_MEMAE, PAPER_VUNET

    compact_memae = dict(PAPER_MEMAE, features_root=16, num_slots=500, shrink_thres=1.0 / 500)
    compact_vunet = dict(PAPER_VUNET, nf_start=32, nf_max=64)
    return {"paper": (PAPER_MEMAE, PAPER_VUNET), "compact": (compact_memae, compact_vunet)}


def worker(config: str, stage: int, threads: int) -> dict:
    import torch
    import torch.nn.functional as F

    torch.set_num_threads(threads)
    torch.set_num_interop_threads(1)
    sys.path.insert(0, HERE)
    from hf2vad_reference import build_hfvad
    from parity_check import entropy_sum, gradient_loss, intensity_loss, kl_loss

    torch.manual_seed(0)
    memae_cfg, vunet_cfg = configs()[config]
    model = build_hfvad(memae_cfg, vunet_cfg)
    batch = BATCH[stage]
    frames = torch.rand(batch, 15, 32, 32)
    flows = torch.randn(batch, 8, 32, 32) * 2.0

    if stage == 1:
        net = model.memAE
        net.train()
        params, lr = net.parameters(), 1e-4
    elif stage == 2:
        model.memAE.eval()
        for p in model.memAE.parameters():
            p.requires_grad_(False)
        model.vunet.train()
        params, lr = model.vunet.parameters(), 1e-4
    else:
        model.train()
        params, lr = model.parameters(), 8e-5
    optim = torch.optim.Adam(params, lr=lr, eps=1e-7)

    def step():
        if stage == 1:
            target = flows[:, 6:8]
            o = net(target)
            loss = F.mse_loss(o["recon"], target) + 0.0002 * entropy_sum(
                [o["att_weight1"], o["att_weight2"], o["att_weight3"]]
            )
        else:
            o = model(frames, flows, mode="train")
            kl, _ = kl_loss(o["q_means"], o["p_means"])
            loss = kl + intensity_loss(o["frame_pred"], o["frame_target"]) + gradient_loss(
                o["frame_pred"], o["frame_target"]
            )
            if stage == 3:
                loss = loss + F.mse_loss(o["of_recon"], o["of_target"]) + 0.0002 * entropy_sum(
                    [o["att_weight1"], o["att_weight2"], o["att_weight3"]]
                )
        optim.zero_grad()
        loss.backward()
        optim.step()

    for _ in range(2):
        step()
    times = []
    start = time.perf_counter()
    while len(times) < 3 or time.perf_counter() - start < 10.0:
        t0 = time.perf_counter()
        step()
        times.append(time.perf_counter() - t0)
    return {
        "config": config,
        "stage": stage,
        "threads": threads,
        "batch": batch,
        "median_s": statistics.median(times),
        "min_s": min(times),
        "max_s": max(times),
        "n": len(times),
        "samples_per_s": batch / statistics.median(times),
        "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "torch": torch.__version__,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--configs", nargs="+", default=["paper", "compact"])
    parser.add_argument("--stages", nargs="+", type=int, default=[1, 2, 3])
    parser.add_argument("--threads", nargs="+", type=int, default=[1, 2])
    parser.add_argument("--out", help="JSON file for the results")
    parser.add_argument("--worker", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        config, stage, threads = args.worker
        print(json.dumps(worker(config, int(stage), int(threads))))
        return
    rows = []
    print(f"{'config':8s} {'stage':>5s} {'threads':>7s} {'batch':>5s} {'median s':>9s} "
          f"{'min–max s':>13s} {'n':>3s} {'samples/s':>9s} {'peak MiB':>8s}")
    for config in args.configs:
        for stage in args.stages:
            for threads in args.threads:
                out = subprocess.run(
                    [sys.executable, __file__, "--worker", config, str(stage), str(threads)],
                    check=True, capture_output=True, text=True,
                ).stdout
                r = json.loads(out.strip().splitlines()[-1])
                rows.append(r)
                print(f"{config:8s} {stage:5d} {threads:7d} {r['batch']:5d} {r['median_s']:9.3f} "
                      f"{r['min_s']:6.3f}–{r['max_s']:6.3f} {r['n']:3d} {r['samples_per_s']:9.1f} "
                      f"{r['peak_rss_mib']:8.0f}", flush=True)
    if args.out:
        with open(args.out, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
