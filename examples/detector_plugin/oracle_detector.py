#!/usr/bin/env python3
"""An "oracle" detector for scene-gen's plug-in protocol (see crates/perception/src/detection/mod.rs): it answers
every request with the boxes of a COCO ground-truth file, score 1. It proves the protocol
round trip (external process -> scene-gen's COCO evaluation -> AP = 1) and is a template for
a real detector. Standard library only.

usage: oracle_detector.py --gt GROUND_TRUTH.json  < requests.jsonl > responses.jsonl
"""
import argparse
import json
import sys
from collections import defaultdict


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gt", required=True, help="COCO ground-truth JSON file")
    args = ap.parse_args()
    with open(args.gt) as f:
        gt = json.load(f)
    boxes = defaultdict(list)
    for a in gt["annotations"]:
        if not a.get("iscrowd", 0):
            boxes[a["image_id"]].append({"category_id": a["category_id"], "bbox": a["bbox"], "score": 1.0})
    for line in sys.stdin:
        if not line.strip():
            continue
        req = json.loads(line)
        # A real detector would read req["path"] (an image file) here.
        sys.stdout.write(json.dumps({"image_id": req["image_id"], "detections": boxes.get(req["image_id"], [])}) + "\n")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
