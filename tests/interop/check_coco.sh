#!/usr/bin/env bash
# COCO bbox evaluation (crates/perception/src/detection/coco_eval.rs, via examples/coco_eval.rs) against
# pycocotools' COCOeval on random sets, plus the external-detector plug-in round trip with
# examples/detector_plugin/oracle_detector.py. PROFILE=debug uses a debug build.
set -euo pipefail
cd "$(dirname "$0")/../.."
profile="${PROFILE:-release}"
if [ "$profile" = release ]; then
  cargo build --release --quiet --example coco_eval
else
  cargo build --quiet --example coco_eval
fi
echo "check_coco: scene-gen COCO evaluation vs pycocotools COCOeval (bbox, area all, maxDets 100)"
.venv/bin/python tests/interop/coco_eval_check.py "target/$profile/examples/coco_eval" --sets "${COCO_SETS:-200}"
