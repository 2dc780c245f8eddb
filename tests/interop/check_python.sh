#!/usr/bin/env bash
# The scene_gen Python package (pyproject.toml, crates/python, python/scene_gen): `pip install .`
# into .venv/ (maturin builds the native module), the type stubs checked against the built
# module (mypy's stubtest) and the package typed strictly (mypy --strict), then the pytest
# suite in python/tests, which compares every call with the command line's output
# (target/release/scene-gen, or $SCENE_GEN_BIN).
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
.venv/bin/python -m pytest -q -p no:cacheprovider python/tests
