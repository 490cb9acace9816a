#!/usr/bin/env bash
# Peak resident memory of `vadscope eval --boxes gt` scoring 2, 8 and 32 uncached braking
# scenarios (384×256, 80 frames each, from `generate --preset test`): it should stay flat in
# the number of scenarios, since eval lets each scenario's decoded frames go once scored
# and keeps only its score table. Prints a Markdown table (scenarios, peak RSS, ratio to
# the 2-scenario run).
# Usage: bash benches/eval_memory.sh [WORK_DIR]   (default /tmp/vadscope-eval-memory)
set -euo pipefail
cd "$(dirname "$0")/.."
work="${1:-/tmp/vadscope-eval-memory}"
cargo build --release --quiet
vadscope="$PWD/target/release/vadscope"
mkdir -p "$work"
if [ ! -f "$work/all/.complete" ]; then
  rm -rf "$work/all"
  "$vadscope" generate --out "$work/all" --preset test --count 32 --seed 3 \
    --omit depth,instance > "$work/generate.log" 2>&1
  touch "$work/all/.complete"
fi
mapfile -t scenarios < <(find "$work/all" -mindepth 1 -maxdepth 1 -type d | sort)
echo "| scenarios | peak RSS | ratio to 2 |"
echo "|---|---|---|"
base=""
for n in 2 8 32; do
  set_dir="$work/n$n"
  rm -rf "$set_dir"
  mkdir -p "$set_dir"
  # Hard links of the generated files: no score cache, so every scenario is scored.
  for s in "${scenarios[@]:0:$n}"; do
    cp -al "$s" "$set_dir/"
    rm -rf "$set_dir/$(basename "$s")/.vadscope"
  done
  /usr/bin/time -f "%M" -o "$work/time$n" "$vadscope" eval "$set_dir" --boxes gt --by none \
    > "$work/eval$n.md" 2> "$work/eval$n.log"
  read -r kb < "$work/time$n"
  base="${base:-$kb}"
  echo "| $n | $((kb / 1024)) MB | $(awk -v a="$kb" -v b="$base" 'BEGIN { printf "%.2f", a / b }') |"
done
