#!/usr/bin/env bash
# Regenerates the bundled sample scenarios exactly (tests/synth/sample_sequences.rs checks that the
# committed files are what these commands produce). Depth and flow are left out to keep the
# bundle small; vadscope computes flow with its DIS engine when a scenario has none.
set -euo pipefail
cd "$(dirname "$0")"
rm -rf Scenario_*
common=(--frames 80 --size 384x256 --omit depth,flow)
cargo run --release --quiet -- generate --out . --kind braking --domain city --weather sun --seed 7 "${common[@]}"
cargo run --release --quiet -- generate --out . --kind normal --domain highway --weather rain --seed 8 "${common[@]}"
