"""Time PyTorch CPU inference of the HF²-VAD reference networks at the paper configuration,
following the method of `shared/design/pytorch-cpu-anchor.md` ("Method" and "Load control").

Networks (random weights, PyTorch default init; speed does not depend on the weight values):
- `memae`  ML-MemAE-SC, one flow per call: input [B, 2, 32, 32].
- `hfvad`  full HF²-VAD STC (4 memAE passes + CVAE), `mode="test"` including the reference's
           z sample at 4x4: frames [B, 15, 32, 32], flows [B, 8, 32, 32].

Method, per configuration (network × threads × batch), each in a fresh process:
- `torch.set_num_threads(N)`, `torch.set_num_interop_threads(1)`; `model.eval()`, every call
  inside `torch.no_grad()`.
- Warm-up: 3 calls (memae) / 2 calls (hfvad).
- Load guard: wait until processes other than this one use < 0.15 cores (busy jiffies in
  /proc/stat minus this process's own CPU time), then time; measure the other-process usage
  during the timing too and repeat the measurement (up to 3 attempts) if it exceeded 0.15 cores.
- One `time.perf_counter()` interval per call; at least 7 / 5 calls (memae / hfvad), continuing
  until 6 s / 8 s have elapsed, at most 40 / 30 calls (full mode). `--quick`: 5 / 3 calls,
  1.5 s / 2 s, at most 20 / 10 calls.
- Reported: median, min and max ms per call, n, throughput = B / median, the 1-minute load average
  (it includes this benchmark's own threads), other-process cores during the timing, VM steal.

Usage (driver; spawns one worker process per configuration):
    /work/torchenv/bin/python benches/pytorch_anchor/time_inference.py [--quick]
        [--nets memae hfvad] [--threads 1 2] [--batch 1 16 64] [--out results.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time

sys.dont_write_bytecode = True  # keep the repository free of __pycache__
HERE = os.path.dirname(os.path.abspath(__file__))

CLK_TCK = os.sysconf("SC_CLK_TCK")

# MACs per call unit (spec B.8): one memAE pass on one flow; one full STC.
MMAC = {"memae": 285.2, "hfvad": 2119.5}
UNIT = {"memae": "cubes/s", "hfvad": "STC/s"}
NAME = {"memae": "ML-MemAE-SC, 1 flow", "hfvad": "HF²-VAD, full STC (4 memAE + CVAE)"}

SCHEDULE = {
    #        warmup, min_reps, min_time_s, max_reps
    "full": {"memae": (3, 7, 6.0, 40), "hfvad": (2, 5, 8.0, 30)},
    "quick": {"memae": (3, 5, 1.5, 20), "hfvad": (2, 3, 2.0, 10)},
}


# ---------------------------------------------------------------------------------------------
# Load measurement
# ---------------------------------------------------------------------------------------------


def read_stat():
    """(busy jiffies, steal jiffies) summed over all CPUs. busy = user+nice+system+irq+softirq."""
    with open("/proc/stat") as f:
        parts = f.readline().split()
    v = [int(x) for x in parts[1:]]
    user, nice, system, idle, iowait, irq, softirq, steal = (v + [0] * 8)[:8]
    return user + nice + system + irq + softirq, steal


class Window:
    """Measures other-process core usage over an interval."""

    def start(self):
        self.busy0, self.steal0 = read_stat()
        self.cpu0 = time.process_time()  # this process, all threads
        self.wall0 = time.perf_counter()

    def stop(self):
        busy1, steal1 = read_stat()
        cpu1 = time.process_time()
        wall = time.perf_counter() - self.wall0
        own = cpu1 - self.cpu0
        busy = (busy1 - self.busy0) / CLK_TCK
        return {
            "wall_s": wall,
            "own_cores": own / wall,
            "other_cores": max(0.0, (busy - own) / wall),
            "other_cores_raw": (busy - own) / wall,
            "steal_s": (steal1 - self.steal0) / CLK_TCK,
        }


def wait_quiet(threshold, window_s, max_wait_s):
    """Wait until other-process usage over one window is below threshold (or max_wait_s passed)."""
    t0 = time.perf_counter()
    last = None
    while True:
        w = Window()
        w.start()
        time.sleep(window_s)
        last = w.stop()
        waited = time.perf_counter() - t0
        if last["other_cores"] < threshold:
            return {"quiet": True, "waited_s": waited, "other_cores": last["other_cores"]}
        if waited >= max_wait_s:
            return {"quiet": False, "waited_s": waited, "other_cores": last["other_cores"]}


def loadavg1():
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


# ---------------------------------------------------------------------------------------------
# Worker: one configuration in this (fresh) process
# ---------------------------------------------------------------------------------------------


def run_worker(args):
    import torch

    torch.set_num_threads(args.threads)
    torch.set_num_interop_threads(1)
    sys.path.insert(0, HERE)
    import hf2vad_reference as R

    torch.manual_seed(args.seed)
    net = args.net
    b = args.batch
    if net == "memae":
        model = R.paper_memae()
        inputs = (2.0 * torch.randn(b, 2, 32, 32),)
        call = lambda: model(*inputs)  # noqa: E731
    else:
        model = R.paper_hfvad()
        inputs = (torch.rand(b, 15, 32, 32), 2.0 * torch.randn(b, 8, 32, 32))
        call = lambda: model(*inputs, mode="test")  # noqa: E731
    model.eval()
    n_params = R.count_params(model)

    warmup, min_reps, min_time, max_reps = SCHEDULE["quick" if args.quick else "full"][net]
    with torch.no_grad():
        t_w = time.perf_counter()
        for _ in range(warmup):
            call()
        warmup_s = time.perf_counter() - t_w

        attempts = []
        for attempt in range(args.max_attempts):
            guard = wait_quiet(args.other_threshold, args.guard_window, args.max_wait)
            times = []
            w = Window()
            w.start()
            t_start = time.perf_counter()
            while True:
                t0 = time.perf_counter()
                call()
                times.append(time.perf_counter() - t0)
                elapsed = time.perf_counter() - t_start
                if len(times) >= min_reps and (elapsed >= min_time or len(times) >= max_reps):
                    break
            load = w.stop()
            attempts.append({"guard": guard, "load": load, "times_s": times, "loadavg1": loadavg1(),
                             "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())})
            if load["other_cores"] <= args.other_threshold:
                break

    best = min(attempts, key=lambda a: a["load"]["other_cores"])
    t_ms = [t * 1e3 for t in best["times_s"]]
    med = statistics.median(t_ms)
    res = {
        "net": net, "threads": args.threads, "batch": b, "quick": args.quick,
        "median_ms": med, "min_ms": min(t_ms), "max_ms": max(t_ms), "n": len(t_ms),
        "throughput_per_s": b / (med / 1e3), "unit": UNIT[net],
        "gmac_per_s": MMAC[net] * b / med,  # MMAC·B / ms = GMAC/s
        "loadavg1": best["loadavg1"], "other_cores": best["load"]["other_cores"],
        "own_cores": best["load"]["own_cores"], "steal_s": best["load"]["steal_s"],
        "contaminated": best["load"]["other_cores"] > args.other_threshold,
        "guard_waited_s": best["guard"]["waited_s"], "guard_quiet": best["guard"]["quiet"],
        "n_attempts": len(attempts), "warmup_calls": warmup, "warmup_s": warmup_s,
        "times_ms": t_ms, "utc": best["utc"], "n_params": n_params,
        "torch_num_threads": torch.get_num_threads(), "torch_num_interop_threads": torch.get_num_interop_threads(),
        "attempts": [{k: v for k, v in a.items() if k != "times_s"} for a in attempts],
    }
    print("RESULT " + json.dumps(res), flush=True)


# ---------------------------------------------------------------------------------------------
# Driver
# ---------------------------------------------------------------------------------------------


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def environment():
    import numpy
    import torch
    return {
        "cpu_model": cpu_model(), "nproc": os.cpu_count(), "python": platform.python_version(),
        "torch": torch.__version__, "numpy": numpy.__version__,
        "cpu_capability": torch.backends.cpu.get_cpu_capability(),
        "mkldnn": torch.backends.mkldnn.is_available(), "parallel_info": torch.__config__.parallel_info(),
        "host": platform.node(), "kernel": platform.release(),
    }


def fmt_row(r):
    return (f"| {NAME[r['net']] if r['_first'] else ''} | {r['threads']} | {r['batch']} | {r['median_ms']:.1f} | "
            f"{r['min_ms']:.1f} – {r['max_ms']:.1f} | {r['n']} | **{r['throughput_per_s']:.1f} {r['unit']}** | "
            f"{r['gmac_per_s']:.0f} | {r['loadavg1']:.2f} | {r['other_cores']:.3f} | {r['steal_s']:.2f} |"
            + (" contaminated" if r["contaminated"] else ""))


def run_driver(args):
    env = environment()
    mode = "quick" if args.quick else "full"
    print(f"# PyTorch CPU inference timing ({mode}), {env['cpu_model']}, {env['nproc']} CPUs, torch {env['torch']}, "
          f"capability {env['cpu_capability']}", flush=True)
    w = Window()
    w.start()
    time.sleep(1.0)
    now = w.stop()["other_cores"]
    print(f"other-process usage now: {now:.2f} cores (guard threshold {args.other_threshold}; each attempt waits "
          f"up to {args.max_wait:.0f} s for a quiet machine)", flush=True)
    rows = []
    t_all = time.perf_counter()
    for net in args.nets:
        for th in args.threads:
            for b in args.batch:
                cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--net", net, "--threads", str(th),
                       "--batch", str(b), "--seed", str(args.seed), "--other-threshold", str(args.other_threshold),
                       "--max-wait", str(args.max_wait), "--max-attempts", str(args.max_attempts),
                       "--guard-window", str(args.guard_window)] + (["--quick"] if args.quick else [])
                t0 = time.perf_counter()
                p = subprocess.run(cmd, capture_output=True, text=True,
                                   env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})
                lines = [ln for ln in p.stdout.splitlines() if ln.startswith("RESULT ")]
                if p.returncode != 0 or not lines:
                    print(f"worker failed: {' '.join(cmd)}\n{p.stdout}\n{p.stderr}", file=sys.stderr)
                    sys.exit(1)
                r = json.loads(lines[-1][len("RESULT "):])
                r["process_wall_s"] = time.perf_counter() - t0
                rows.append(r)
                print(f"  {net:5s} threads={th} B={b:<3d} median {r['median_ms']:9.1f} ms  "
                      f"({r['min_ms']:.1f} – {r['max_ms']:.1f}, n={r['n']})  {r['throughput_per_s']:7.1f} {r['unit']}  "
                      f"load1 {r['loadavg1']:.2f}  other {r['other_cores']:.3f} cores  "
                      f"[{r['process_wall_s']:.0f} s]" + ("  CONTAMINATED" if r["contaminated"] else ""), flush=True)
    total = time.perf_counter() - t_all

    print("\n| network | threads | B | median ms/call | min – max ms | n | **throughput (median)** | GMAC/s | "
          "loadavg 1 min | other cores | steal s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    prev = None
    for r in rows:
        r["_first"] = r["net"] != prev
        prev = r["net"]
        print(fmt_row(r))
        del r["_first"]
    print(f"\ntotal {total:.0f} s")

    out = args.out or f"/tmp/vadscope_pytorch_anchor_{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}.json"
    with open(out, "w") as f:
        json.dump({"mode": mode, "environment": env, "total_s": total,
                   "method": "shared/design/pytorch-cpu-anchor.md; fresh process per configuration",
                   "schedule": SCHEDULE[mode], "other_threshold": args.other_threshold, "results": rows}, f, indent=1)
    print(f"wrote {out}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nets", nargs="+", default=["memae", "hfvad"], choices=["memae", "hfvad"])
    ap.add_argument("--threads", nargs="+", type=int, default=[1, 2])
    ap.add_argument("--batch", nargs="+", type=int, default=[1, 16, 64])
    ap.add_argument("--quick", action="store_true", help="fewer repetitions (whole matrix in a few minutes)")
    ap.add_argument("--out", default=None, help="JSON output path (default /tmp/vadscope_pytorch_anchor_<utc>.json)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--other-threshold", type=float, default=0.15, help="max other-process cores (load guard)")
    ap.add_argument("--max-wait", type=float, default=120.0, help="max seconds to wait for a quiet machine per attempt")
    ap.add_argument("--max-attempts", type=int, default=3)
    ap.add_argument("--guard-window", type=float, default=1.0, help="seconds per load-guard sample")
    # worker mode (internal)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--net", choices=["memae", "hfvad"], help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        args.threads = args.threads[0]
        args.batch = args.batch[0]
        run_worker(args)
    else:
        run_driver(args)


if __name__ == "__main__":
    main()
