"""Scores `scene-gen detect --json` output with pycocotools against a scene-gen dataset.

Usage: check_detector.py DATASET RESULTS.json [--floor AP50]

Each result carries the image's path as `file_name`; it is mapped to the dataset's image id,
then COCOeval (bbox) gives AP@0.5 overall and per category. Exits 1 below the floor.
"""

import argparse
import contextlib
import io
import json
import os
import sys

import numpy as np
from pycocotools.coco import COCO
from pycocotools.cocoeval import COCOeval


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("dataset")
    parser.add_argument("results")
    parser.add_argument("--floor", type=float, default=0.02)
    args = parser.parse_args()
    with contextlib.redirect_stdout(io.StringIO()):
        gt = COCO(os.path.join(args.dataset, "annotations", "instances_day.json"))
    images = os.path.realpath(os.path.join(args.dataset, "images"))
    ids = {os.path.join(images, img["file_name"]): img["id"] for img in gt.dataset["images"]}
    with open(args.results) as f:
        records = json.load(f)
    results = []
    for r in records:
        path = os.path.realpath(r["file_name"])
        if path not in ids:
            sys.exit(f"check_detector: result for unknown image {r['file_name']}")
        results.append({"image_id": ids[path], "category_id": r["category_id"], "bbox": r["bbox"], "score": r["score"]})
    if not results:
        sys.exit("check_detector: the detector found nothing")
    with contextlib.redirect_stdout(io.StringIO()):
        dt = gt.loadRes(results)
        ev = COCOeval(gt, dt, "bbox")
        ev.evaluate()
        ev.accumulate()
        ev.summarize()
    ap50 = ev.stats[1]
    # precision[T, R, K, A, M]: IoU 0.5, every recall, category k, area all, 100 detections.
    precision = ev.eval["precision"]
    names = {c["id"]: c["name"] for c in gt.dataset["categories"]}
    counts = {k: len(gt.getAnnIds(catIds=[k])) for k in names}
    print(f"  {len(gt.dataset['images'])} images, {len(gt.dataset['annotations'])} objects, {len(results)} detections")
    for k, cat in enumerate(ev.params.catIds):
        p = precision[0, :, k, 0, 2]
        ap = float(np.mean(p[p > -1])) if (p > -1).any() else float("nan")
        print(f"  {names[cat]:<10} {counts[cat]:>4} objects  AP@0.5 {ap:.3f}")
    print(f"  overall AP@0.5 {ap50:.3f}, AP@[.5:.95] {ev.stats[0]:.3f} (floor {args.floor})")
    if not ap50 >= args.floor:
        sys.exit(f"check_detector: AP@0.5 {ap50:.3f} is below the floor {args.floor}")
    print("check_detector: OK")


if __name__ == "__main__":
    main()
