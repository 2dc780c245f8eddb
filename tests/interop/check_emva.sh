#!/usr/bin/env bash
# `scene-gen calibrate` against the EMVA 1288 reference implementation (the emva1288 package):
# that package's camera simulator makes data sets at 8, 10 and 12 bits (one of them with
# quantization-limited dark noise), its own processing computes the system gain K, the
# temporal dark noise and the quantum efficiency, and calibrate's figures on the same images
# must agree within 3 %. Uses target/release/scene-gen (BIN= overrides).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${BIN:-target/release/scene-gen}"
[ -x "$bin" ] || cargo build --release --quiet --bin scene-gen
.venv/bin/python tests/interop/check_emva.py "$bin"
