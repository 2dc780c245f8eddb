"""Compares scene-gen's COCO evaluator (examples/coco_eval.rs) with pycocotools' COCOeval on
many random ground-truth / detection sets, then runs the oracle detector plug-in round trip.

usage: coco_eval_check.py COCO_EVAL_BINARY [--sets N]

Each set has several images (ids not contiguous), 11 categories (some without ground truth),
jittered true boxes, misses, duplicates, wrong classes, false positives, score ties, crowd
regions, areas that differ from w * h, and now and then more than 100 detections on one
image and class. Half the sets put boxes and scores on exact binary fractions (1/8 px,
1/16 score steps), so IoUs land exactly on the thresholds and scores tie often; the other half
use arbitrary floats. AP@[.5:.95], AP@0.5 and every per-class AP must agree within 1e-6.
"""
import contextlib
import io
import json
import os
import random
import subprocess
import sys
import tempfile

import numpy as np
import importlib.metadata
from pycocotools.coco import COCO
from pycocotools.cocoeval import COCOeval

TOL = 1e-6
N_CATS = 11


def snap(v, exact):
    return round(v * 8) / 8 if exact else v


def make_set(rng, exact):
    n_img = rng.randint(1, 6)
    image_ids = sorted(rng.sample(range(1, 1000), n_img))
    images = [{"id": i, "width": 640, "height": 480, "file_name": f"img_{i}.png"} for i in image_ids]
    cats = [{"id": c, "name": f"class{c}"} for c in range(1, N_CATS + 1)]
    present = rng.sample(range(1, N_CATS + 1), rng.randint(1, N_CATS))
    anns, dets = [], []

    def score():
        return rng.randint(0, 16) / 16 if exact else rng.random()

    def rand_box():
        w, h = snap(rng.uniform(2, 200), exact), snap(rng.uniform(2, 200), exact)
        return [snap(rng.uniform(0, 600), exact), snap(rng.uniform(0, 440), exact), w, h]

    for img in image_ids:
        for _ in range(rng.randint(0, 12)):
            c = rng.choice(present)
            b = rand_box()
            crowd = 1 if rng.random() < 0.05 else 0
            area = b[2] * b[3] if rng.random() < 0.8 else snap(b[2] * b[3] * rng.uniform(0.3, 1.0), exact)
            anns.append({"id": len(anns) + 1, "image_id": img, "category_id": c, "bbox": b,
                         "area": area, "iscrowd": crowd})
            if rng.random() < 0.8:
                for _ in range(2 if rng.random() < 0.2 else 1):
                    j = rng.choice([0.02, 0.1, 0.25])
                    d = [snap(b[0] + rng.gauss(0, j * b[2]), exact), snap(b[1] + rng.gauss(0, j * b[3]), exact),
                         snap(max(1.0, b[2] * rng.uniform(1 - j, 1 + j)), exact),
                         snap(max(1.0, b[3] * rng.uniform(1 - j, 1 + j)), exact)]
                    cd = c if rng.random() > 0.05 else rng.randint(1, N_CATS)
                    dets.append({"image_id": img, "category_id": cd, "bbox": d, "score": score()})
        for _ in range(rng.randint(0, 6)):
            dets.append({"image_id": img, "category_id": rng.randint(1, N_CATS), "bbox": rand_box(),
                         "score": score()})
        if rng.random() < 0.05:
            c = rng.choice(present)
            for _ in range(rng.randint(101, 160)):
                dets.append({"image_id": img, "category_id": c, "bbox": rand_box(), "score": score()})
    if not dets:  # COCO.loadRes cannot take an empty list
        dets.append({"image_id": image_ids[0], "category_id": 1, "bbox": rand_box(), "score": 0.5})
    rng.shuffle(dets)
    return {"images": images, "annotations": anns, "categories": cats}, dets


def pycoco(gt_path, dt_path):
    with contextlib.redirect_stdout(io.StringIO()):
        gt = COCO(gt_path)
        dt = gt.loadRes(dt_path)
        ev = COCOeval(gt, dt, "bbox")
        ev.evaluate()
        ev.accumulate()
        ev.summarize()
    prec = ev.eval["precision"]  # [T, R, K, A, M]; A=0 "all", M=2 maxDets=100
    per = {}
    for k, cid in enumerate(ev.params.catIds):
        p = prec[:, :, k, 0, 2]
        per[cid] = (float(np.mean(p)) if np.all(p > -1) else -1.0,
                    float(np.mean(p[0])) if np.all(p[0] > -1) else -1.0)
    return float(ev.stats[0]), float(ev.stats[1]), per


def ours(binary, *args):
    out = subprocess.run([binary, *args], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def main():
    binary = sys.argv[1]
    n_sets = int(sys.argv[sys.argv.index("--sets") + 1]) if "--sets" in sys.argv else 200
    rng = random.Random(20261121)
    worst = 0.0
    n_cls = 0
    n_dets = 0
    with tempfile.TemporaryDirectory() as tmp:
        for s in range(n_sets):
            exact = s % 2 == 0
            gt, dets = make_set(rng, exact)
            n_dets += len(dets)
            gt_path, dt_path = os.path.join(tmp, f"gt{s}.json"), os.path.join(tmp, f"dt{s}.json")
            with open(gt_path, "w") as f:
                json.dump(gt, f)
            with open(dt_path, "w") as f:
                json.dump(dets, f)
            ap, ap50, per = pycoco(gt_path, dt_path)
            r = ours(binary, gt_path, dt_path)
            pairs = [("ap", ap, r["ap"]), ("ap50", ap50, r["ap50"])]
            ours_per = {c["category_id"]: c for c in r["per_class"]}
            if sorted(ours_per) != sorted(per):
                sys.exit(f"set {s}: categories differ: ours {sorted(ours_per)} pycocotools {sorted(per)}")
            for cid, (cap, cap50) in per.items():
                pairs.append((f"class {cid} ap", cap, ours_per[cid]["ap"]))
                pairs.append((f"class {cid} ap50", cap50, ours_per[cid]["ap50"]))
                n_cls += 1
            for name, want, got in pairs:
                d = abs(want - got)
                worst = max(worst, d)
                if d > TOL:
                    sys.exit(f"set {s} ({'exact' if exact else 'float'}): {name}: pycocotools {want!r}, "
                             f"scene-gen {got!r}")
        print(f"check_coco: {n_sets} random sets ({n_dets} detections, {n_cls} per-class APs) agree with "
              f"pycocotools {importlib.metadata.version('pycocotools')} (numpy {np.__version__}); "
              f"largest difference {worst:.3g} (tolerance {TOL:g})")

        # Plug-in round trip: the oracle answers with the ground-truth boxes -> AP = 1.
        gt, _ = make_set(random.Random(7), True)
        for a in gt["annotations"]:
            a["iscrowd"] = 0
        if not gt["annotations"]:
            sys.exit("oracle set has no annotations")
        gt_path = os.path.join(tmp, "oracle_gt.json")
        with open(gt_path, "w") as f:
            json.dump(gt, f)
        oracle = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "detector_plugin", "oracle_detector.py")
        r = ours(binary, gt_path, "--plugin", sys.executable, oracle, "--gt", gt_path)
        if abs(r["ap"] - 1.0) > 1e-9 or abs(r["ap50"] - 1.0) > 1e-9:
            sys.exit(f"oracle plug-in round trip: AP {r['ap']}, AP50 {r['ap50']}, expected 1")
        print(f"check_coco: oracle detector plug-in round trip over {len(gt['images'])} images, "
              f"{len(gt['annotations'])} boxes: AP {r['ap']:.12f}, AP50 {r['ap50']:.12f}")


if __name__ == "__main__":
    main()
