#!/bin/bash
# scene-gen's global illumination against Mitsuba 3's path tracer, one view per room of a house.
#   bash examples/mitsuba/setup.sh                                  # once: .venv-mitsuba + libLLVM 19
#   bash examples/mitsuba/run_gi_compare.sh [OUT] [SEED] [gi_compare.py options, e.g. --spp 256]
#   GI_VIEWS_ARGS="--render-seed 2" bash examples/mitsuba/run_gi_compare.sh OUT 7 --reuse
#     (gi_views options; --reuse keeps the Mitsuba renders of an earlier run in OUT/mitsuba)
# Prints the volume's build, the per-room table and PASS/FAIL on the 5 % gate (exit status 1).
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-/tmp/scene-gen-gi}
seed=${2:-7}
shift 2 || shift $# || true
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM-19.so}
cargo build --release --quiet --example gi_views --bin scene-gen
# gi_views first: it refuses bad GI_VIEWS_ARGS (status 2) before anything is written.
# shellcheck disable=SC2086 # GI_VIEWS_ARGS is a list of options
target/release/examples/gi_views --seed "$seed" --out "$out/views" ${GI_VIEWS_ARGS:-}
target/release/scene-gen --seed "$seed" --format obj --out "$out/obj" > /dev/null
echo "load before: $(uptime)"
.venv-mitsuba/bin/python examples/mitsuba/gi_compare.py --views "$out/views" --obj "$out/obj/scene.obj" \
    --out "$out/mitsuba" "$@"
echo "load after: $(uptime)"
