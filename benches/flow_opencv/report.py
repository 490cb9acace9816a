"""Turns the JSON lines of one benchmark run into the markdown table of the README.

    python report.py RUN_DIR   (reads acc_*.jsonl and time_*.jsonl, prints markdown)

Accuracy: mean over pairs of the EPE over all pixels, over valid pixels, and of the mean
32x32 vehicle-patch EPE (pairs without boxes are skipped for the latter). Time: for each
tool, preset and thread count, the median over rounds of the per-round figure (the mean
over pairs of the per-pair median time). Ratios are vadscope / OpenCV.
"""
import collections
import glob
import json
import os
import statistics
import sys


def load(pattern):
    rows = []
    for path in sorted(glob.glob(pattern)):
        with open(path) as f:
            rows += [json.loads(line) for line in f if line.strip()]
    return rows


def mean(values):
    return sum(values) / len(values) if values else float("nan")


def fmt(value, digits=3):
    return "–" if value != value else f"{value:.{digits}f}"


def ratio(a, b):
    return "–" if a != a or b != b or b == 0 else f"{a / b:.2f}"


def main():
    run = sys.argv[1]
    acc = collections.defaultdict(lambda: collections.defaultdict(list))
    per_pair = collections.defaultdict(dict)
    for r in load(os.path.join(run, "acc_*.jsonl")):
        key = (r["tool"], r["preset"])
        headline = r["epe_all"] if r["epe_all"] is not None else r["epe_valid"]
        if r["epe_all"] is not None:
            acc[key]["all"].append(r["epe_all"])
        if r["epe_valid"] is not None:
            acc[key]["valid"].append(r["epe_valid"])
        if r["epe_patch32"]:
            patch = mean([p for p in r["epe_patch32"] if p is not None])
            acc[key]["patch"].append(patch)
            per_pair[key][r["pair"]] = (headline, patch)
        else:
            per_pair[key][r["pair"]] = (headline, None)
    times = collections.defaultdict(list)
    for r in load(os.path.join(run, "time_*.jsonl")):
        times[(r["tool"], r["preset"], r["threads"])].append(r["ms_median"])
    presets = [p for p in ["ultrafast", "fast", "medium", "quality"] if ("vadscope", p) in acc]
    threads = sorted({k[2] for k in times})
    print("| preset | tool | EPE all | EPE valid | EPE 32×32 patch |"
          + "".join(f" ms/pair, {t} thread{'s' if t > 1 else ''} |" for t in threads))
    print("|---|---|---|---|---|" + "---|" * len(threads))
    for p in presets:
        for tool in ["opencv", "vadscope"]:
            a = acc[(tool, p)]
            cells = []
            for t in threads:
                ts = times.get((tool, p, t))
                cells.append(f"{statistics.median(ts):.1f}" if ts else "–")
            print(f"| {p} | {tool} | {fmt(mean(a['all']))} | {fmt(mean(a['valid']))} | "
                  f"{fmt(mean(a['patch']))} | " + " | ".join(cells) + " |")
        ours, cv = acc[("vadscope", p)], acc[("opencv", p)]
        ratio_cells = []
        for t in threads:
            a, b = times.get(("vadscope", p, t)), times.get(("opencv", p, t))
            ratio_cells.append(f"{statistics.median(a) / statistics.median(b):.2f}×" if a and b else "–")
        print(f"| {p} | **vadscope / OpenCV** | {ratio(mean(ours['all']), mean(cv['all']))} | "
              f"{ratio(mean(ours['valid']), mean(cv['valid']))} | "
              f"{ratio(mean(ours['patch']), mean(cv['patch']))} | " + " | ".join(ratio_cells) + " |")
    print()
    print("Worst single pair, vadscope / OpenCV EPE (all pixels, or valid pixels where the "
          "truth is not known everywhere; 32×32 patches):")
    print()
    for p in presets:
        worst_all, worst_patch = (0.0, ""), (0.0, "")
        for pair, (ours_all, ours_patch) in per_pair[("vadscope", p)].items():
            cv_all, cv_patch = per_pair[("opencv", p)].get(pair, (None, None))
            if cv_all and ours_all is not None:
                worst_all = max(worst_all, (ours_all / cv_all, pair))
            if ours_patch is not None and cv_patch:
                worst_patch = max(worst_patch, (ours_patch / cv_patch, pair))
        print(f"- {p}: {worst_all[0]:.2f} ({worst_all[1]}); {worst_patch[0]:.2f} ({worst_patch[1]})")


if __name__ == "__main__":
    main()
