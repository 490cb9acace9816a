#!/usr/bin/env bash
# Renders the gallery of docs/gallery/ from the two sample scenarios with the bundled model
# (or the checkpoint in $VADSCOPE_MODEL). The scenarios are copied to a temporary folder
# first, so their score caches and estimated flows never land in the repository.
#
#   bash docs/gallery/regenerate.sh            (or VADSCOPE_BIN=path/to/vadscope bash ...)
set -euo pipefail
cd "$(dirname "$0")/../.."
# VADSCOPE_BIN names an already built binary; else a dev build (dependencies optimised).
bin=${VADSCOPE_BIN:-}
if [ -z "$bin" ]; then
  cargo build --quiet
  bin=target/debug/vadscope
fi
out=docs/gallery
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

braking=Scenario_0000_braking_city_sun_b55dae386ce69990
normal=Scenario_0000_normal_highway_rain_87a23e74b37809c0
cp -r "sample_sequences/$braking" "sample_sequences/$normal" "$work/"

# Sudden braking: the anomaly window is frames 40-56.
"$bin" render "$work/$braking" --frames 48 --view dashboard --size 1280x800 --out "$work/b"
"$bin" render "$work/$braking" --frames 48 --view frame,pred,flow --out "$work/b"
"$bin" render "$work/$braking" --view timeline,roc --out "$work/b"
cp "$work/b/dashboard_00048.png" "$out/braking_dashboard.png"
cp "$work/b/frame_00048.png" "$out/braking_frame.png"
cp "$work/b/pred_00048.png" "$out/braking_pred.png"
cp "$work/b/flow_00048.png" "$out/braking_flow.png"
cp "$work/b/timeline.png" "$out/braking_timeline.png"
cp "$work/b/roc.png" "$out/braking_roc.png"
cp "$work/b/histogram.png" "$out/braking_histogram.png"

# Normal driving in rain: no anomaly, so no ROC.
"$bin" render "$work/$normal" --frames 40 --view frame --out "$work/n"
"$bin" render "$work/$normal" --view timeline --out "$work/n"
cp "$work/n/frame_00040.png" "$out/normal_frame.png"
cp "$work/n/timeline.png" "$out/normal_timeline.png"
ls -l "$out"/*.png
