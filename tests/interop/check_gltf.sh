#!/usr/bin/env bash
# Runs the Khronos glTF validator (npm gltf-validator, pinned in package.json) on the GLBs of
# generated scenes (three seeds at the default envelope, two at 20x10x2.8), on a .gltf +
# .bin + textures export, and on the hand-made feature scene of
# examples/gltf_feature_scene.rs (every exporter feature: shared meshes, labels, u32
# indices, translucent glass, point / rect / directional lights). Fails on any validator
# error or warning, or if two exports of the same seed differ.
set -euo pipefail

bin=target/release/scene-gen
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

files=()
for seed in 7 1 42; do
  "$bin" --seed "$seed" --out "$tmp/seed$seed"
  files+=("$tmp/seed$seed/scene.glb")
done
for seed in 7 3; do
  "$bin" --seed "$seed" --envelope 20x10x2.8 --out "$tmp/wide$seed"
  files+=("$tmp/wide$seed/scene.glb")
done
"$bin" --seed 7 --format gltf --out "$tmp/gltf7"
files+=("$tmp/gltf7/scene.gltf")

"$bin" --seed 7 --out "$tmp/again7"
cmp "$tmp/seed7/scene.glb" "$tmp/again7/scene.glb"
echo "check_gltf: seed 7 exports byte-identical GLBs twice"

cargo run --release --quiet --example gltf_feature_scene -- "$tmp/feature.glb"
files+=("$tmp/feature.glb")

node tests/interop/validate_gltf.js "${files[@]}"
echo "check_gltf: ${#files[@]} files, 0 validator errors, 0 warnings"
