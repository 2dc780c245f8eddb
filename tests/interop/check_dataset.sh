#!/usr/bin/env bash
# scene-gen dataset (crates/design/src/dataset/) against pycocotools: a two-shard dataset of two houses is
# loaded with COCO(), every annotation's mask.decode equals the instance-mask PNG pixels of its
# instance, and COCOeval of the ground truth as detections (score 1) gives AP 1.0 for bbox
# and segm, by day and by night. Uses target/release/scene-gen (BIN= overrides).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${BIN:-target/release/scene-gen}"
[ -x "$bin" ] || cargo build --release --quiet --bin scene-gen
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
args=(--seeds 0..2 --camera IMX174,focal_mm=3 --frames 6 --max-width 160 --quality preview --out "$out/ds")
echo "check_dataset: scene-gen dataset ${args[*]:0:10} as two shards, then pycocotools"
"$bin" dataset "${args[@]}" --shard 0/2 >/dev/null
"$bin" dataset "${args[@]}" --shard 1/2 >/dev/null
.venv/bin/python tests/interop/check_dataset.py "$out/ds"
