#!/usr/bin/env bash
# Reproduces the bundled model assets/model/hf2vad_ad_compact.safetensors: generates the
# normal-driving training scenarios and the validation scenarios (sudden braking, never the
# test preset), trains the compact HF²-VAD_AD on the former with `vadscope train` in six
# runs, keeping the epochs of runs 3 and 6 by their frame AUROC on the latter (run 6's
# candidates from its 11th epoch on being the running average of the weights; run 6 judges
# on 12 validation scenarios, two sets of 6), and copies the final checkpoint here. MODEL.md records
# the runs, their wall times and what the model detects. Each step's start is logged with
# its time, so the wall times can be read off the output.
# Usage: bash assets/model/reproduce.sh [WORK_DIR]   (default /tmp/vadscope-bundled; it must
# not hold an earlier run)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
work="${1:-/tmp/vadscope-bundled}"
cd "$here/../.."
cargo build --release --quiet
vadscope=target/release/vadscope
common=(--data "$work/train" --seed 0 --frame-stride 3)
step() { echo "== $(date -u +%H:%M:%S) $*"; }

step "generate: 48 normal-driving scenarios of 120 frames at 768×512 (4,553 training cubes)"
"$vadscope" generate --out "$work/train" --preset train --count 48 --frames 120 --seed 0 \
  --omit depth,semantic,instance
step "run 1: stage 1 for 5 epochs and stage 2 for 2, both cores; boxes of at least 1/400 of the frame that the image edge does not cut"
"$vadscope" train "${common[@]}" --out "$work/run1" --preset compact --box-filter driving \
  --memae-epochs 5 --cvae-epochs 2 --finetune-epochs 0 --batch 32 --memae-lr 1e-3 --cvae-lr 1e-3
# The second set of 48 scenarios (seed 100), for run 6, and the validation scenarios that
# runs 3 and 6 select by, generated on the core run 2 leaves free.
step "generate (in the background): 48 more normal-driving scenarios, seed 100, and 2×6 validation braking scenarios, seeds 1 and 2"
(
  "$vadscope" generate --out "$work/train2" --preset train --count 48 --frames 120 --seed 100 \
    --omit depth,semantic,instance
  "$vadscope" generate --out "$work/val" --preset test --count 6 --seed 1 \
    --omit depth,semantic,instance
  "$vadscope" generate --out "$work/val2" --preset test --count 6 --seed 2 \
    --omit depth,semantic,instance
  # Run 6 judges on both sets: one folder of links to their scenarios.
  mkdir -p "$work/val12"
  for set in val val2; do
    for scenario in "$work/$set"/Scenario_*; do
      ln -s "$scenario" "$work/val12/Scenario_${set}_$(basename "$scenario" | cut -d_ -f2-)"
    done
  done
) > "$work/generate-background.log" 2>&1 &
background=$!
step "run 2: stage 1 for 20 more epochs, one thread"
"$vadscope" train "${common[@]}" --out "$work/run2" --init "$work/run1/model.safetensors" \
  --stage memae --memae-epochs 20 --batch 32 --memae-lr 1e-3 --threads 1
step "waiting for the background generation"
wait "$background"
step "run 3: stage 1 for 25 more epochs, one thread, every fifth epoch judged by its validation frame AUROC (on both cores), then the training statistics per 5 vertical bands of the image"
"$vadscope" train "${common[@]}" --out "$work/run3" --init "$work/run2/model.safetensors" \
  --stage memae --memae-epochs 25 --batch 32 --memae-lr 1e-3 --score-bands 5 --threads 1 \
  --select-on "$work/val" --select-every 5 --select-threads 2
step "run 4: one more stage-1 epoch at a lower learning rate (3e-4), one thread"
"$vadscope" train "${common[@]}" --out "$work/run4" --init "$work/run3/model.safetensors" \
  --stage memae --memae-epochs 1 --batch 32 --memae-lr 3e-4 --score-bands 5 --threads 1
step "run 5: the flows named in pixels of a 768-wide frame (the training frames' width), so scoring rescales the flows of frames of other widths; cubes and statistics unchanged"
"$vadscope" train "${common[@]}" --out "$work/run5" --init "$work/run4/model.safetensors" \
  --epochs 0 --flow-units frame-width
step "run 6: stage 1 for 20 more epochs at 3e-4 on both sets (96 scenarios), shuffle and split seed 1, one thread, the weights of epochs 11 on averaged, every second epoch judged on the 12 validation scenarios; statistics as tail tables per band"
"$vadscope" train --data "$work/train" "$work/train2" --seed 1 --frame-stride 3 \
  --out "$work/run6" --init "$work/run5/model.safetensors" --stage memae --memae-epochs 20 \
  --batch 32 --memae-lr 3e-4 --score-bands 5 --score-scale tail --threads 1 \
  --select-on "$work/val12" --select-every 2 --select-threads 2 --average-from 11
cp "$work/run6/model.safetensors" "$here/hf2vad_ad_compact.safetensors"
step "done: $here/hf2vad_ad_compact.safetensors"
