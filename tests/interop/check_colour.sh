#!/usr/bin/env bash
# The ColorChecker through the colour camera, scored by an outside implementation: `scene-gen
# target colour` photographs the 24-patch chart (noise off, no vignetting) by day (D65) and by
# night (warm white); scikit-image's rgb2lab and deltaE_ciede2000 score the written PNGs against
# the published sRGB values. Gates: every patch's CIEDE2000 agrees with ours within 0.05, and
# the daylight mean is at most 3 for every camera. Uses target/release/scene-gen (BIN= overrides).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${BIN:-target/release/scene-gen}"
[ -x "$bin" ] || cargo build --release --quiet --bin scene-gen
.venv/bin/python tests/interop/check_colour.py "$bin"
