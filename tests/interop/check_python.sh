#!/usr/bin/env bash
# The scene_gen Python package (pyproject.toml, crates/python, python/scene_gen): `pip install .`
# into .venv/ (maturin builds the native module), the type stubs checked against the built
# module (mypy's stubtest) and the package typed strictly (mypy --strict), then the pytest
# suite in python/tests, which compares every call with the command line's output
# (target/release/scene-gen, or $SCENE_GEN_BIN), the Ray runs on a local two-worker cluster
# among them. Last, examples/ray/scale_out.py (the script docs/PYTHON.md runs on a cluster)
# makes a dataset on a local loopback cluster that must equal `scene-gen dataset`'s byte for
# byte. Every step is bounded in time.
set -euo pipefail
cd "$(dirname "$0")/../.."
[ -x target/release/scene-gen ] || cargo build --release --quiet --bin scene-gen
echo "check_python: pip install . (maturin)"
.venv/bin/python -m pip install -q --disable-pip-version-check .
echo "check_python: stubs (mypy stubtest) and types (mypy --strict)"
# From a folder without python/ on the path, so the installed package is what is checked.
elsewhere="$(mktemp -d)"
trap 'rm -rf "$elsewhere"' EXIT
(cd "$elsewhere" && "$OLDPWD/.venv/bin/python" -m mypy.stubtest scene_gen._native)
.venv/bin/python -m mypy --strict --no-error-summary python/scene_gen
echo "check_python: pytest python/tests"
# Ray binds to loopback only (a Linux node otherwise uses its network address).
export RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0
timeout 1200 .venv/bin/python -m pytest -q -p no:cacheprovider python/tests
echo "check_python: examples/ray/scale_out.py on a local cluster against scene-gen dataset"
args=(--camera IMX174,focal_mm=3 --seeds 0..3 --frames 2 --max-width 64 --quality preview)
target/release/scene-gen dataset --quiet "${args[@]}" --out "$elsewhere/cli" >/dev/null
timeout 600 .venv/bin/python examples/ray/scale_out.py --local-cpus 2 dataset "${args[@]}" --out "$elsewhere/ray"
diff -r "$elsewhere/cli" "$elsewhere/ray"
echo "check_python: the Ray script's dataset equals the command line's"
