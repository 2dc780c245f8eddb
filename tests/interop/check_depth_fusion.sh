#!/usr/bin/env bash
# Depth fusion: a small dataset's depth images, back-projected with the K and camera-to-world
# pose of their COCO entries, land on the house's GLB surfaces (median point-to-mesh distance
# under 1 cm per image, trimesh's closest-point query; check_depth_fusion.py). The same check
# with every camera moved 3 cm along each axis must fail. Needs .venv (scripts/test makes it).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=target/release/scene-gen
python=.venv/bin/python
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

seed=6
"$bin" --seed "$seed" --out "$work/house"
"$bin" dataset --quiet --seeds "$seed" --camera IMX174,focal_mm=4,pitch_deg=-10 --frames 4 --max-width 160 \
  --quality preview --lighting day --out "$work/dataset" >/dev/null
echo "seed $seed, 4 frames:"
"$python" tests/interop/check_depth_fusion.py "$work/dataset" "$work/house/scene.glb"
if "$python" tests/interop/check_depth_fusion.py "$work/dataset" "$work/house/scene.glb" --shift-m 0.03 >/dev/null 2>&1; then
  echo "check_depth_fusion: cameras moved 3 cm along each axis passed" >&2
  exit 1
fi
echo "  cameras moved 3 cm along each axis are caught"
echo "check_depth_fusion: passed"
