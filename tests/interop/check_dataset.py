"""Checks a scene-gen dataset folder with pycocotools.

usage: check_dataset.py DIR

For each DIR/annotations/instances_<lighting>.json:
* COCO() loads it; every image file, depth and mask PNG it names exists, and every image is an
  8-bit picture of the annotated size;
* for every annotation, pycocotools' mask.decode(annToRLE) equals (mask PNG == instance_id),
  mask.area equals `area`, and mask.toBbox equals `bbox`;
* COCOeval of the annotations as detections (score 1) gives AP = 1.0 for bbox and segm.
"""
import contextlib
import copy
import io
import json
import os
import sys

import cv2
import numpy as np
from pycocotools import mask as mask_util
from pycocotools.coco import COCO
from pycocotools.cocoeval import COCOeval


def read_png16(path):
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    assert img is not None and img.dtype == np.uint16, f"{path}: not a 16-bit PNG"
    return img.astype(np.int64)


def check(root, path):
    with contextlib.redirect_stdout(io.StringIO()):
        coco = COCO(path)
    cats = sorted(coco.getCatIds())
    assert cats == list(range(1, 12)), f"categories {cats}"
    n_ann = 0
    for img_id in sorted(coco.getImgIds()):
        img = coco.loadImgs(img_id)[0]
        for key in ("depth_file", "mask_file"):
            assert os.path.isfile(os.path.join(root, img[key])), img[key]
        picture = cv2.imread(os.path.join(root, "images", img["file_name"]), cv2.IMREAD_UNCHANGED)
        assert picture is not None, img["file_name"]
        assert picture.dtype == np.uint8 and picture.shape[:2] == (img["height"], img["width"]), (picture.shape, img)
        ids = read_png16(os.path.join(root, img["mask_file"]))
        assert ids.shape == (img["height"], img["width"]), (ids.shape, img)
        for ann in coco.loadAnns(coco.getAnnIds(imgIds=[img_id])):
            n_ann += 1
            rle = coco.annToRLE(ann)
            m = mask_util.decode(rle)
            want = (ids == ann["instance_id"]).astype(np.uint8)
            assert np.array_equal(m, want), f"annotation {ann['id']}: RLE differs from the mask PNG"
            assert int(mask_util.area(rle)) == ann["area"] == int(want.sum()), f"annotation {ann['id']}: area"
            assert list(mask_util.toBbox(rle)) == ann["bbox"], f"annotation {ann['id']}: bbox"
            assert ann["iscrowd"] == 0
    assert n_ann > 0, f"{path}: no annotations"
    dets = []
    for ann in coco.dataset["annotations"]:
        det = {k: copy.deepcopy(ann[k]) for k in ("image_id", "category_id", "bbox", "segmentation")}
        det["score"] = 1.0
        dets.append(det)
    aps = {}
    for iou_type in ("bbox", "segm"):
        with contextlib.redirect_stdout(io.StringIO()):
            res = coco.loadRes(copy.deepcopy(dets))
            ev = COCOeval(coco, res, iou_type)
            ev.evaluate()
            ev.accumulate()
            ev.summarize()
        aps[iou_type] = (ev.stats[0], ev.stats[1])
        assert abs(ev.stats[0] - 1.0) < 1e-12 and abs(ev.stats[1] - 1.0) < 1e-12, f"{iou_type} AP {ev.stats[:2]}"
    print(f"  {os.path.basename(path)}: {len(coco.getImgIds())} images, {n_ann} annotations; masks, areas, boxes "
          f"agree; AP bbox {aps['bbox'][0]:.3f} (AP50 {aps['bbox'][1]:.3f}), segm {aps['segm'][0]:.3f} "
          f"(AP50 {aps['segm'][1]:.3f})")


def main():
    root = sys.argv[1]
    files = sorted(os.listdir(os.path.join(root, "annotations")))
    assert files, "no annotation files"
    for name in files:
        check(root, os.path.join(root, "annotations", name))
    print("check_dataset: ok")


if __name__ == "__main__":
    main()
