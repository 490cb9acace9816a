#!/usr/bin/env bash
# Renders the gallery of docs/gallery/ from the two sample scenarios with the bundled model
# (or the checkpoint in $VADSCOPE_MODEL). The scenarios are copied to a temporary folder
# first, so their score caches and estimated flows never land in the repository. Images
# over 300 KB are stored as 256-colour PNGs (ImageMagick) to keep the repository small.
#
#   bash docs/gallery/regenerate.sh     (VADSCOPE_BIN=path/to/vadscope, GALLERY_WORK=dir: below)
set -euo pipefail
cd "$(dirname "$0")/../.."
# VADSCOPE_BIN names an already built binary; else a dev build (dependencies optimised).
bin=${VADSCOPE_BIN:-}
if [ -z "$bin" ]; then
  cargo build --quiet
  bin=target/debug/vadscope
fi
out=docs/gallery
braking=Scenario_0000_braking_city_sun_b55dae386ce69990
normal=Scenario_0000_normal_highway_rain_87a23e74b37809c0
# GALLERY_WORK names a folder kept between runs: the copies and their score caches are
# made once there (a cache is keyed by the model, so a new model is scored again).
if [ -n "${GALLERY_WORK:-}" ]; then
  work=$GALLERY_WORK
  mkdir -p "$work"
else
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
fi
for scenario in "$braking" "$normal"; do
  [ -d "$work/$scenario" ] || cp -r "sample_sequences/$scenario" "$work/"
done

# Sudden braking: the anomaly window is frames 40-56.
"$bin" render "$work/$braking" --frames 48 --view dashboard --size 1280x800 --out "$work/b"
"$bin" render "$work/$braking" --frames 48 --view frame --size 900x640 --out "$work/b"
"$bin" render "$work/$braking" --frames 48 --view pred,flow --out "$work/b"
"$bin" render "$work/$braking" --view timeline,roc --out "$work/b"
cp "$work/b/dashboard_00048.png" "$out/braking_dashboard.png"
cp "$work/b/frame_00048.png" "$out/braking_frame.png"
cp "$work/b/pred_00048.png" "$out/braking_pred.png"
cp "$work/b/flow_00048.png" "$out/braking_flow.png"
cp "$work/b/timeline.png" "$out/braking_timeline.png"
cp "$work/b/roc.png" "$out/braking_roc.png"
cp "$work/b/histogram.png" "$out/braking_histogram.png"

# Normal driving in rain: no anomaly, so no ROC.
"$bin" render "$work/$normal" --frames 40 --view frame --size 900x640 --out "$work/n"
"$bin" render "$work/$normal" --view timeline --out "$work/n"
cp "$work/n/frame_00040.png" "$out/normal_frame.png"
cp "$work/n/timeline.png" "$out/normal_timeline.png"
for png in "$out"/*.png; do
  if [ "$(stat -c %s "$png")" -gt 300000 ]; then
    convert "$png" -dither FloydSteinberg -colors 256 "PNG8:$png"
  fi
done
ls -l "$out"/*.png
