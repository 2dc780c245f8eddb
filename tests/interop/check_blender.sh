#!/usr/bin/env bash
# GLB round trip through Blender (the `bpy` module, pinned in requirements-blender.txt, in a venv
# of its own, .venv-blender/, because bpy 5.0.1 needs numpy<2): imports scene.glb headless and
# checks the object count, the `class` custom property (from the glTF node extras) on each
# object node and the world bounds within 1 mm of the manifest (check_blender.py).
#
# First a self-test on a hand-made GLB of the contract (make_test_glb.py): it must pass, the
# same GLB with the manifest's table moved 2 mm must fail, and an empty GLB must fail. Then two
# generated seeds (GLB), and the USD export of seed 3 through Blender's
# USD importer (needs usd-core in .venv/, as check_usd.sh does). Installing bpy takes about 30 s
# from a warm pip cache (about 400 MB).
set -euo pipefail
cd "$(dirname "$0")/../.."

venv=.venv-blender
if [ ! -x "$venv/bin/python" ]; then
  python3 -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' \
    || { echo "check_blender: bpy 5.0.1 needs Python 3.11, python3 is $(python3 --version)" >&2; exit 1; }
  python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q --disable-pip-version-check -r tests/interop/requirements-blender.txt
python="$venv/bin/python"
bin=target/release/scene-gen
cargo build --release --quiet --bin scene-gen  # a no-op after scripts/test built it

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
quiet() { grep -v '| INFO:' || true; }

echo "self-test on a hand-made contract GLB:"
"$python" tests/interop/make_test_glb.py "$work/good"
"$python" tests/interop/check_blender.py "$work/good/scene.glb" 2>&1 | quiet
[ "${PIPESTATUS[0]}" = 0 ] || { echo "check_blender: the hand-made GLB should pass" >&2; exit 1; }
"$python" tests/interop/make_test_glb.py "$work/shifted" --shift-mm 2
if "$python" tests/interop/check_blender.py "$work/shifted/scene.glb" >/dev/null 2>&1; then
  echo "check_blender: a table 2 mm off its manifest bounds passed" >&2; exit 1
fi
: > "$work/empty.glb"
if "$python" tests/interop/check_blender.py "$work/empty.glb" "$work/good/scene.json" >/dev/null 2>&1; then
  echo "check_blender: an empty GLB passed" >&2; exit 1
fi
echo "  a 2 mm bound error and an empty GLB are both caught"

# The USD export, through Blender's USD importer (a second tool reading the same stage).
for format in usda usdc; do
  SCENE_GEN_PYTHON=.venv/bin/python "$bin" --seed 3 --format "$format" --out "$work/usd-$format"
  echo "USD ($format, seed 3):"
  "$python" tests/interop/check_blender.py "$work/usd-$format/scene.$format" 2>&1 | quiet
  [ "${PIPESTATUS[0]}" = 0 ] || { echo "check_blender: seed 3 $format failed" >&2; exit 1; }
done

# The OBJ export through Blender's OBJ importer, default options: one Blender object per node.
# The same file without its `o` lines must fail (Blender then merges the house into one object).
"$bin" --seed 4 --format obj --out "$work/obj4"
echo "OBJ (seed 4):"
"$python" tests/interop/check_blender.py "$work/obj4/scene.obj" 2>&1 | quiet
[ "${PIPESTATUS[0]}" = 0 ] || { echo "check_blender: seed 4 obj failed" >&2; exit 1; }
mkdir -p "$work/obj4-merged"
cp -r "$work/obj4/scene.mtl" "$work/obj4/textures" "$work/obj4/scene.json" "$work/obj4-merged/"
grep -v '^o ' "$work/obj4/scene.obj" > "$work/obj4-merged/scene.obj"
if "$python" tests/interop/check_blender.py "$work/obj4-merged/scene.obj" >/dev/null 2>&1; then
  echo "check_blender: an OBJ without 'o' lines passed (objects merged)" >&2; exit 1
fi
echo "  the same OBJ without its 'o' lines is caught (Blender merges it into one object)"

for seed in 1 2; do
  "$bin" --seed "$seed" --format glb --out "$work/s$seed"
  echo "seed $seed:"
  "$python" tests/interop/check_blender.py "$work/s$seed/scene.glb" 2>&1 | quiet
  [ "${PIPESTATUS[0]}" = 0 ] || { echo "check_blender: seed $seed failed" >&2; exit 1; }
done
echo "check_blender: passed"
