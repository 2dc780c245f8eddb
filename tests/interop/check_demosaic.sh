#!/usr/bin/env bash
# Demosaicing against OpenCV on photographs: colour photographs that ship with scikit-image
# are mosaicked (every CFA pattern in turn), developed back with `scene-gen isp --only-demosaic`
# by each method, and scored by PSNR against the original beside OpenCV's cvtColor Bayer
# conversions (bilinear and edge-aware) in the same run. Gates: our bilinear within 0.5 dB of
# OpenCV's (the mosaic's phase is read right), and our best edge-aware method at least 1 dB
# above OpenCV's edge-aware conversion on every photograph. Uses target/release/scene-gen
# (BIN= overrides).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${BIN:-target/release/scene-gen}"
[ -x "$bin" ] || cargo build --release --quiet --bin scene-gen
.venv/bin/python tests/interop/check_demosaic.py "$bin"
