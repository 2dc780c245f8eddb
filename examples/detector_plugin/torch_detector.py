#!/usr/bin/env python3
"""A real detector for scene-gen's plug-in protocol (crates/perception/src/detection/mod.rs): torchvision's
Faster R-CNN (ResNet-50-FPN), the network TaCOS used.

Runs on the user's own machine; scene-gen's tests never run it (they have no PyTorch). Needs
`pip install torch torchvision pillow`.

Two modes:
* `--weights FILE`: a state dict fine-tuned on scene-gen data with 12 outputs (background +
  scene-gen's categories 1..=11), e.g. from `scene-gen dataset` annotations. Labels are
  scene-gen category ids as they are.
* no `--weights`: the COCO-pretrained model, its COCO labels mapped by name onto scene-gen's
  classes (couch -> sofa, tv/laptop -> computer, sink -> basin, teddy bear -> toy, ...).
  Bathtubs, lamps and thresholds have no COCO class and are never reported in this mode.

usage: torch_detector.py [--weights FILE] [--device cuda|cpu] [--min-score 0.05]
        < requests.jsonl > responses.jsonl
"""
import argparse
import json
import sys

# scene-gen category ids (docs/CONTRACTS.md): 1 sofa, 2 bed, 3 table, 4 chair, 5 bathtub, 6 basin,
# 7 computer, 8 plant, 9 lamp, 10 toy, 11 threshold.
COCO_NAME_TO_SCENE_GEN = {
    "couch": 1, "bed": 2, "dining table": 3, "chair": 4, "sink": 6,
    "tv": 7, "laptop": 7, "potted plant": 8, "teddy bear": 10,
}


def main():
    ap = argparse.ArgumentParser(description="torchvision Faster R-CNN behind scene-gen's detector protocol")
    ap.add_argument("--weights", help="fine-tuned state dict with 12 classes (background + 11)")
    ap.add_argument("--device", default=None)
    ap.add_argument("--min-score", type=float, default=0.05)
    args = ap.parse_args()

    import torch
    import torchvision
    from PIL import Image
    from torchvision.transforms.functional import to_tensor

    device = args.device or ("cuda" if torch.cuda.is_available() else "cpu")
    if args.weights:
        model = torchvision.models.detection.fasterrcnn_resnet50_fpn(weights=None, weights_backbone=None,
                                                                     num_classes=12)
        model.load_state_dict(torch.load(args.weights, map_location="cpu"))
        label_map = {i: i for i in range(1, 12)}
    else:
        w = torchvision.models.detection.FasterRCNN_ResNet50_FPN_Weights.COCO_V1
        model = torchvision.models.detection.fasterrcnn_resnet50_fpn(weights=w)
        names = w.meta["categories"]
        label_map = {i: COCO_NAME_TO_SCENE_GEN[n] for i, n in enumerate(names) if n in COCO_NAME_TO_SCENE_GEN}
    model.eval().to(device)

    with torch.no_grad():
        for line in sys.stdin:
            if not line.strip():
                continue
            req = json.loads(line)
            img = to_tensor(Image.open(req["path"]).convert("RGB")).to(device)
            out = model([img])[0]
            dets = []
            for box, label, score in zip(out["boxes"].tolist(), out["labels"].tolist(), out["scores"].tolist()):
                if score < args.min_score or label not in label_map:
                    continue
                x0, y0, x1, y1 = box
                dets.append({"category_id": label_map[label], "bbox": [x0, y0, x1 - x0, y1 - y0], "score": score})
            sys.stdout.write(json.dumps({"image_id": req["image_id"], "detections": dets}) + "\n")
            sys.stdout.flush()


if __name__ == "__main__":
    main()
