#!/bin/bash
# scene-gen against Mitsuba 3 on the seed-7 house, same view and workloads, one run.
#   bash examples/mitsuba/setup.sh            # once: .venv-mitsuba + libLLVM 19
#   bash examples/mitsuba/run_compare.sh [OUT] [compare.py options, e.g. --res 640x480 --spp 1]
# Prints the load average before and after (the machine is shared), the view check and a table.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-/tmp/scene-gen-mitsuba}
shift || true
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM-19.so}
cargo build --release --quiet --example bench_render --bin scene-gen
target/release/scene-gen --seed 7 --format obj --out "$out/obj" > /dev/null
echo "load before: $(uptime)"
.venv-mitsuba/bin/python examples/mitsuba/compare.py --bench target/release/examples/bench_render \
    --obj "$out/obj/scene.obj" --out "$out" "$@"
echo "load after: $(uptime)"
