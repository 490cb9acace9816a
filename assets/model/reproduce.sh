#!/usr/bin/env bash
# Reproduces the bundled model assets/model/hf2vad_ad_compact.safetensors: generates the
# normal-driving training scenarios, trains the compact HF²-VAD_AD on them with
# `vadscope train`, and copies the final checkpoint here. MODEL.md records the run.
# Usage: bash assets/model/reproduce.sh [WORK_DIR]   (default /tmp/vadscope-bundled; it must
# not hold an earlier run)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
work="${1:-/tmp/vadscope-bundled}"
cd "$here/../.."
cargo build --release --quiet
vadscope=target/release/vadscope
"$vadscope" generate --out "$work/data" --preset train --count 48 --frames 24 --size 384x256 \
  --seed 0 --omit depth,semantic,instance
"$vadscope" train --data "$work/data" --out "$work/run" --preset compact --seed 0 \
  --frame-stride 8 --memae-epochs 10 --cvae-epochs 3 --finetune-epochs 1 --batch 32 \
  --memae-lr 1e-3 --cvae-lr 1e-3 --finetune-lr 1e-4
cp "$work/run/model.safetensors" "$here/hf2vad_ad_compact.safetensors"
