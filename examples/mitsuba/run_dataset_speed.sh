#!/bin/bash
# Dataset frames per second: scene-gen against Mitsuba 3 on the same frames of one house.
#   bash examples/mitsuba/setup.sh                      # once: .venv-mitsuba + libLLVM 19
#   bash examples/mitsuba/run_dataset_speed.sh [OUT] [dataset_speed.py options, e.g. --quality standard]
# Prints the load average before and after (the machine is shared), one JSON line per case and
# a table.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-/tmp/scene-gen-dataset-speed}
shift || true
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM-19.so}
cargo build --release --quiet --bin scene-gen
echo "load before: $(uptime)"
.venv-mitsuba/bin/python examples/mitsuba/dataset_speed.py --bin target/release/scene-gen --out "$out" "$@"
echo "load after: $(uptime)"
