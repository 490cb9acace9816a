"""OpenCV's DIS on the benchmark pairs: writes its flows for scoring, or times it.

    python opencv_dis.py flows PAIRS_DIR OUT_DIR     -> OUT_DIR/<preset>/<pair>.flo
    python opencv_dis.py time PAIRS_DIR --threads N --reps R [--presets a,b]

Presets: ultrafast, fast, medium are OpenCV's; quality = medium with finest scale 0.
Timing prints one JSON line per preset with the same fields as examples/flow_bench.rs:
per pair the median (and minimum) over R runs after one warm-up run, averaged over pairs.
"""
import argparse
import json
import os
import time

import cv2
import numpy as np

PRESETS = ["ultrafast", "fast", "medium", "quality"]


def make_dis(preset):
    code = {"ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
            "fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
            "medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM,
            "quality": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM}[preset]
    dis = cv2.DISOpticalFlow_create(code)
    if preset == "quality":
        dis.setFinestScale(0)
    return dis


def load_pairs(folder):
    with open(os.path.join(folder, "manifest.json")) as f:
        manifest = json.load(f)
    out = []
    for p in manifest["pairs"]:
        a = cv2.imread(os.path.join(folder, p["frame0"]), cv2.IMREAD_GRAYSCALE)
        b = cv2.imread(os.path.join(folder, p["frame1"]), cv2.IMREAD_GRAYSCALE)
        if a is None or b is None:
            raise SystemExit(f"cannot read frames of pair {p['name']} in {folder}")
        out.append((p["name"], a, b))
    return out


def write_flo(path, flow):
    h, w = flow.shape[:2]
    with open(path, "wb") as f:
        np.array([202021.25], "<f4").tofile(f)
        np.array([w, h], "<i4").tofile(f)
        np.ascontiguousarray(flow, "<f4").tofile(f)


def flows(args):
    for preset in args.presets:
        os.makedirs(os.path.join(args.out, preset), exist_ok=True)
        dis = make_dis(preset)
        for name, a, b in load_pairs(args.pairs):
            write_flo(os.path.join(args.out, preset, name + ".flo"), dis.calc(a, b, None))


def timing(args):
    cv2.setNumThreads(args.threads)
    pairs = load_pairs(args.pairs)[:args.max_pairs]
    for preset in args.presets:
        dis = make_dis(preset)
        medians, mins = [], []
        for _, a, b in pairs:
            dis.calc(a, b, None)
            ms = []
            for _ in range(max(1, args.reps)):
                t0 = time.perf_counter()
                dis.calc(a, b, None)
                ms.append((time.perf_counter() - t0) * 1e3)
            medians.append(float(np.median(ms)))
            mins.append(float(np.min(ms)))
        print(json.dumps(dict(kind="time", tool="opencv", preset=preset, threads=args.threads,
                              reps=args.reps, pairs=len(pairs), ms_median=float(np.mean(medians)),
                              ms_min=float(np.mean(mins)), version=cv2.__version__)), flush=True)


def main():
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("flows")
    f.add_argument("pairs")
    f.add_argument("out")
    t = sub.add_parser("time")
    t.add_argument("pairs")
    t.add_argument("--threads", type=int, default=1)
    t.add_argument("--reps", type=int, default=10)
    t.add_argument("--max-pairs", type=int, default=None, help="time only the first N pairs")
    for p in (f, t):
        p.add_argument("--presets", type=lambda s: s.split(","), default=PRESETS)
    args = ap.parse_args()
    flows(args) if args.cmd == "flows" else timing(args)


if __name__ == "__main__":
    main()
