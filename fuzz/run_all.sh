#!/usr/bin/env bash
# Runs every fuzz target for RUNS executions or SECONDS seconds, whichever comes first, with
# the resource limits of README.md, and prints one line per target: executions, coverage,
# features, corpus size, wall time and whether it found anything.
#   bash fuzz/run_all.sh [RUNS] [SECONDS] [TARGET...]   (defaults: 1000000, 1800, every target)
set -uo pipefail
cd "$(dirname "$0")"
runs=${1:-1000000}
seconds=${2:-1800}
shift $(( $# < 2 ? $# : 2 ))
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  mapfile -t targets < <(cargo +nightly fuzz list)
fi
export TMPDIR=${TMPDIR:-/dev/shm}
mkdir -p logs
for target in "${targets[@]}"; do
  mkdir -p "corpus/$target"
  start=$(date +%s)
  cargo +nightly fuzz run "$target" "corpus/$target" "seeds/$target" -- \
    -runs="$runs" -max_total_time="$seconds" -rss_limit_mb=2048 -malloc_limit_mb=1024 \
    -timeout=10 -print_final_stats=1 > "logs/$target.log" 2>&1
  status=$?
  wall=$(( $(date +%s) - start ))
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "logs/$target.log" | grep -o '[0-9]*$')
  last=$(grep -E '^#[0-9]+' "logs/$target.log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' <<< "$last" | grep -o '[0-9]*')
  ft=$(grep -o 'ft: [0-9]*' <<< "$last" | grep -o '[0-9]*')
  corpus=$(ls "corpus/$target" | wc -l)
  verdict=$([ "$status" -eq 0 ] && echo "0 crashes" || echo "FOUND (exit $status, see logs/$target.log)")
  echo "| \`$target\` | ${execs:-?} | ${cov:-?} | ${ft:-?} | $corpus | ${wall} s | $verdict |"
done
