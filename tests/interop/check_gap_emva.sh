#!/usr/bin/env bash
# `scene-gen gap` on EMVA 1288 data sets made by the reference implementation's camera simulator
# (the emva1288 package), with effects hidden in them: the named effects must be exactly the
# hidden ones in 90 % of the cases (8, 10 and 12 bits, one 640x480 set) and a clean set must get
# a false name in at most 5 % of 30 seeds. Uses target/release/scene-gen (BIN= overrides).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${BIN:-target/release/scene-gen}"
[ -x "$bin" ] || cargo build --release --quiet --bin scene-gen
.venv/bin/python tests/interop/check_gap_emva.py "$bin"
