#!/usr/bin/env bash
# Side-by-side benchmark of vadscope's DIS optical flow against OpenCV's DIS: same frames,
# same machine, one run. Prints a markdown table (also saved as $WORK/report.md).
#
#   benches/flow_opencv/run.sh            # from the repository root
#
# Environment: WORK (scratch folder, default /tmp/vadscope-flow-bench), ROUNDS (timing
# rounds alternating the two tools, default 3), REPS (timed runs per pair and round,
# default 10), PAIRS (driving, the default, or affine), CARGO_TARGET_DIR (as for cargo). OpenCV is installed with pip into a
# throwaway venv under $WORK; it is a measuring stick only, never a vadscope dependency.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
WORK="${WORK:-/tmp/vadscope-flow-bench}"
ROUNDS="${ROUNDS:-3}"
REPS="${REPS:-10}"
PRESETS="ultrafast,fast,medium,quality"
mkdir -p "$WORK"

echo "== OpenCV in a throwaway venv ($WORK/venv)"
if [ ! -x "$WORK/venv/bin/python" ]; then
    python3 -m venv "$WORK/venv"
fi
"$WORK/venv/bin/pip" install --quiet --disable-pip-version-check opencv-python-headless numpy
PY="$WORK/venv/bin/python"

echo "== release build of examples/flow_bench"
(cd "$ROOT" && cargo build --release --example flow_bench)
BIN="${CARGO_TARGET_DIR:-$ROOT/target}/release/examples/flow_bench"

# Frame pairs with exact flow. Default: vadscope's generated driving scenarios (city and
# highway, sun and rain, 768x512), every 4th frame. PAIRS=affine uses make_pairs.py's
# affine textured scenes instead (a second, generator-independent check).
PAIRS="${PAIRS:-driving}"
echo "== $PAIRS frame pairs with exact flow ($WORK/pairs-$PAIRS)"
if [ ! -f "$WORK/pairs-$PAIRS/manifest.json" ]; then
    if [ "$PAIRS" = affine ]; then
        "$PY" "$HERE/make_pairs.py" "$WORK/pairs-$PAIRS"
    else
        "$BIN" generate --out "$WORK/scenarios"
        "$BIN" export-pairs --scenarios "$WORK"/scenarios/Scenario_* --out "$WORK/pairs-$PAIRS"
    fi
fi
PAIR_DIR="$WORK/pairs-$PAIRS"

RUN="$WORK/run-$(date +%Y%m%d-%H%M%S)"
mkdir -p "$RUN"
{
    echo "date: $(date -Iseconds)"
    echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | xargs), $(nproc) cores"
    echo "opencv: $("$PY" -c 'import cv2; print(cv2.__version__)')"
    echo "vadscope: $(cd "$ROOT" && git rev-parse --short HEAD 2>/dev/null || echo unknown)"
    echo "pairs: $PAIRS ($(grep -o '"name"' "$PAIR_DIR/manifest.json" | wc -l) pairs)"
    echo "load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
} > "$RUN/machine.txt"

echo "== accuracy (both tools scored by the same Rust code)"
"$PY" "$HERE/opencv_dis.py" flows "$PAIR_DIR" "$RUN/opencv_flows" --presets "$PRESETS"
"$BIN" accuracy --pairs "$PAIR_DIR" --presets "$PRESETS" \
    --external "$RUN/opencv_flows" --label opencv > "$RUN/acc_opencv.jsonl"
"$BIN" accuracy --pairs "$PAIR_DIR" --presets "$PRESETS" > "$RUN/acc_vadscope.jsonl"

echo "== timing: $ROUNDS rounds x 1 and 2 threads, tools alternating"
for round in $(seq 1 "$ROUNDS"); do
    for threads in 1 2; do
        "$PY" "$HERE/opencv_dis.py" time "$PAIR_DIR" --threads "$threads" --reps "$REPS" \
            --presets "$PRESETS" >> "$RUN/time_opencv.jsonl"
        "$BIN" time --pairs "$PAIR_DIR" --threads "$threads" --reps "$REPS" \
            --presets "$PRESETS" >> "$RUN/time_vadscope.jsonl"
        echo "   round $round, $threads thread(s) done"
    done
done
echo "load average at end: $(cut -d' ' -f1-3 /proc/loadavg)" >> "$RUN/machine.txt"

"$PY" "$HERE/report.py" "$RUN" > "$RUN/report.md"
cp "$RUN/report.md" "$WORK/report.md"
echo
cat "$RUN/machine.txt"
echo
cat "$RUN/report.md"
