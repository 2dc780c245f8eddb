#!/usr/bin/env python3
"""Trains scene-gen's learned detector with PyTorch on the CPU.

The same network, targets, loss and schedule as `scene-gen detector train` (Rust, candle), for
speed: PyTorch's oneDNN convolutions train the network about 13 times faster on two cores
(docs/BENCHMARKS.md, "The learned detector"). Besides the flips it zooms each image by a random
factor (as a longer or shorter lens would see the room) and scales its brightness.

The result is the file scene-gen reads: `detector.safetensors` with batch normalisation folded
into the convolutions, under the layer names of crates/perception/src/detection/cnn/network.rs. After each epoch the weights are
scored on the held-out dataset by `scene-gen detect --json` and pycocotools, so the number in
`validation.tsv` is the Rust detector's own.

    scripts/train_detector.py --data DIR... --validation DIR --out DIR [--epochs N]
        [--batch 16] [--learning-rate 3e-3] [--seed 0] [--threads N] [--no-augment]
        [--scene-gen BIN] [--init WEIGHTS]

With --init it starts from a finished `detector.safetensors` instead of random weights, its
normalisation frozen (the file holds no statistics), for a warm restart of the schedule.

Run it through `scripts/train_detector --trainer torch`, which renders the data and installs
the pinned PyTorch into .venv-train/.
"""

import argparse
import contextlib
import io
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
from PIL import Image
from safetensors.torch import save_file
from torch import nn

# The network's shape: name, input channels, output channels, kernel side, stride. Must match
# LAYERS in crates/perception/src/detection/cnn/network.rs (scene-gen refuses a file whose
# tensors have other names or shapes).
NUM_CLASSES = 11
BOX_CHANNELS = 4
STRIDE_PX = 8
PAD_TO_PX = 32
LAYERS = [
    ("stem", 3, 12, 3, 2),
    ("s4a", 12, 24, 3, 2),
    ("s4b", 24, 24, 3, 1),
    ("s8a", 24, 48, 3, 2),
    ("s8b", 48, 48, 3, 1),
    ("s16a", 48, 96, 3, 2),
    ("s16b", 96, 96, 3, 1),
    ("s32a", 96, 128, 3, 2),
    ("s32b", 128, 128, 3, 1),
    ("up16", 128 + 96, 96, 3, 1),
    ("up8", 96 + 48, 48, 3, 1),
    ("head", 48, 48, 3, 1),
    ("heat", 48, NUM_CLASSES, 1, 1),
    ("box", 48, BOX_CHANNELS, 1, 1),
]
NORMALISED_LAYERS = len(LAYERS) - 2
HEAT_PRIOR_BIAS = -2.19
INPUT_MEAN = 0.45
INPUT_SPREAD = 0.25
GAUSSIAN_ALPHA = 0.54
MIN_SIGMA_CELLS = 0.35


class Detector(nn.Module):
    """The encoder, the two-level pyramid and the heads; batch-normalised hidden layers."""

    def __init__(self):
        super().__init__()
        self.convs = nn.ModuleList(nn.Conv2d(cin, cout, k, s, k // 2) for _, cin, cout, k, s in LAYERS)
        self.norms = nn.ModuleList(nn.BatchNorm2d(cout, eps=1e-5, momentum=0.1) for _, _, cout, _, _ in LAYERS[:NORMALISED_LAYERS])
        for conv in self.convs:
            nn.init.kaiming_uniform_(conv.weight, a=0, nonlinearity="relu")
            nn.init.zeros_(conv.bias)
        nn.init.constant_(self.convs[12].bias, HEAT_PRIOR_BIAS)

    def layer(self, i, x):
        return torch.relu(self.norms[i](self.convs[i](x)))

    def forward(self, x):
        for i in range(4):
            x = self.layer(i, x)
        f8 = self.layer(4, x)
        f16 = self.layer(6, self.layer(5, f8))
        x = self.layer(8, self.layer(7, f16))
        x = self.layer(9, torch.cat([nn.functional.interpolate(x, size=f16.shape[2:], mode="nearest"), f16], 1))
        x = self.layer(10, torch.cat([nn.functional.interpolate(x, size=f8.shape[2:], mode="nearest"), f8], 1))
        x = self.layer(11, x)
        return self.convs[12](x), self.convs[13](x)

    def folded(self):
        """Inference weights: each normalisation folded into its convolution."""
        out = {}
        for i, (name, *_rest) in enumerate(LAYERS):
            w = self.convs[i].weight.detach().clone()
            b = self.convs[i].bias.detach().clone()
            if i < NORMALISED_LAYERS:
                n = self.norms[i]
                factor = n.weight.detach() / torch.sqrt(n.running_var + n.eps)
                w = w * factor[:, None, None, None]
                b = (b - n.running_mean) * factor + n.bias.detach()
            out[f"{name}.weight"] = w.contiguous().float()
            out[f"{name}.bias"] = b.contiguous().float()
        return out

    def load_folded(self, path):
        """Starts from inference weights (a `detector.safetensors`): each convolution takes its
        folded weights and every normalisation becomes the identity with frozen statistics, so
        the network computes exactly what scene-gen computes from the file."""
        from safetensors.torch import load_file

        try:
            tensors = load_file(str(path))
        except Exception as e:  # a missing file, or not safetensors
            bad_input(f"{path}: {e}")
        for i, (name, *_rest) in enumerate(LAYERS):
            for part in ("weight", "bias"):
                key = f"{name}.{part}"
                got = tensors.get(key)
                want = getattr(self.convs[i], part)
                if got is None or got.shape != want.shape:
                    bad_input(f"{path}: tensor {key} is missing or not {tuple(want.shape)}")
                with torch.no_grad():
                    want.copy_(got)
        for n in self.norms:
            with torch.no_grad():
                n.weight.fill_(1.0)
                n.bias.zero_()
                n.running_mean.zero_()
                n.running_var.fill_(1.0 - n.eps)
        self.frozen_norms = True

    def train(self, mode=True):
        """Training mode, except that frozen normalisations keep their statistics."""
        super().train(mode)
        if getattr(self, "frozen_norms", False):
            for n in self.norms:
                n.eval()
        return self


def padded(side):
    return -(-side // PAD_TO_PX) * PAD_TO_PX


def encode(boxes, cells_w, cells_h):
    """Heat, box and mask targets of one image, as the Rust encoder makes them."""
    heat = np.zeros((NUM_CLASSES, cells_h, cells_w), np.float32)
    box = np.zeros((BOX_CHANNELS, cells_h, cells_w), np.float32)
    mask = np.zeros((1, cells_h, cells_w), np.float32)
    keep = [b for b in boxes if b[0] < NUM_CLASSES and b[3] > 0 and b[4] > 0]
    # Larger first, so the smaller object's box wins a shared cell (a stable sort, as Rust's).
    keep.sort(key=lambda b: -(np.float32(b[3]) * np.float32(b[4])))
    for cls, x, y, w, h in keep:
        cx, cy = (x + w / 2) / STRIDE_PX, (y + h / 2) / STRIDE_PX
        ix = min(max(math.floor(cx), 0), cells_w - 1)
        iy = min(max(math.floor(cy), 0), cells_h - 1)
        sx = max(GAUSSIAN_ALPHA * w / STRIDE_PX / 6, MIN_SIGMA_CELLS)
        sy = max(GAUSSIAN_ALPHA * h / STRIDE_PX / 6, MIN_SIGMA_CELLS)
        rx, ry = math.ceil(3 * sx), math.ceil(3 * sy)
        y0, y1 = max(iy - ry, 0), min(iy + ry, cells_h - 1)
        x0, x1 = max(ix - rx, 0), min(ix + rx, cells_w - 1)
        dy = np.arange(y0, y1 + 1)[:, None] - iy
        dx = np.arange(x0, x1 + 1)[None, :] - ix
        g = np.exp(-(dx * dx) / (2 * sx * sx) - (dy * dy) / (2 * sy * sy)).astype(np.float32)
        region = heat[cls, y0 : y1 + 1, x0 : x1 + 1]
        np.maximum(region, g, out=region)
        mask[0, iy, ix] = 1
        box[:, iy, ix] = [cx - ix, cy - iy, math.log(w / STRIDE_PX), math.log(h / STRIDE_PX)]
    return heat, box, mask


def bad_input(message):
    """Stops on unusable input: the message on stderr, exit status 2, nothing written."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def annotation_files(folder):
    """The COCO files of a dataset folder, or a bad-input stop when it has none."""
    files = sorted((Path(folder) / "annotations").glob("instances_*.json"))
    if not files:
        bad_input(f"{Path(folder) / 'annotations'}: no instances_*.json (not a scene-gen dataset folder)")
    return files


def load_dataset(folder):
    """(pixels [3, H, W] uint8, boxes [(class, x, y, w, h)]) of every image of a dataset folder."""
    folder = Path(folder)
    samples = []
    for ann in annotation_files(folder):
        try:
            coco = json.loads(ann.read_text())
            by_image = {}
            for a in coco["annotations"]:
                if a.get("iscrowd", 0) == 0 and 1 <= a["category_id"] <= NUM_CLASSES:
                    by_image.setdefault(a["image_id"], []).append((a["category_id"] - 1, *a["bbox"]))
            images = [(folder / "images" / i["file_name"], i["id"]) for i in coco["images"]]
        except (OSError, ValueError, KeyError, TypeError) as e:
            bad_input(f"{ann}: {e}")
        for path, image_id in images:
            try:
                pil = Image.open(path)
                arr = np.asarray(pil.convert("RGB") if pil.mode in ("RGB", "RGBA") else pil.convert("L"))
            except OSError as e:
                bad_input(f"{path}: {e}")
            if arr.ndim == 2:
                arr = np.repeat(arr[:, :, None], 3, axis=2)
            samples.append((np.ascontiguousarray(arr.transpose(2, 0, 1)), by_image.get(image_id, [])))
    if not samples:
        bad_input(f"{folder}: no images")
    return samples


def rescaled(pixels, boxes, scale, rng):
    """The image zoomed by `scale` about a random point and cut or padded back to its size, as a
    longer or shorter lens would see the scene (CenterNet's random-scale augmentation)."""
    _, h, w = pixels.shape
    sw, sh = max(round(w * scale), 8), max(round(h * scale), 8)
    image = np.asarray(Image.fromarray(pixels.transpose(1, 2, 0)).resize((sw, sh), Image.BILINEAR))
    out = np.full((h, w, 3), round(INPUT_MEAN * 255), np.uint8)
    # Offset of the zoomed image in the frame: negative when zooming in (a crop).
    ox = int(rng.integers(min(0, w - sw), max(0, w - sw) + 1))
    oy = int(rng.integers(min(0, h - sh), max(0, h - sh) + 1))
    sx0, sy0 = max(0, -ox), max(0, -oy)
    dx0, dy0 = max(0, ox), max(0, oy)
    cw, ch = min(sw - sx0, w - dx0), min(sh - sy0, h - dy0)
    out[dy0 : dy0 + ch, dx0 : dx0 + cw] = image[sy0 : sy0 + ch, sx0 : sx0 + cw]
    kept = []
    for c, x, y, bw, bh in boxes:
        x0, y0 = max(x * scale + ox, 0), max(y * scale + oy, 0)
        x1, y1 = min((x + bw) * scale + ox, w), min((y + bh) * scale + oy, h)
        # An object cut to less than 40 % of itself, or to a sliver, is no longer a target.
        if x1 - x0 >= 2 and y1 - y0 >= 2 and (x1 - x0) * (y1 - y0) >= 0.4 * bw * bh * scale * scale:
            kept.append((c, x0, y0, x1 - x0, y1 - y0))
    return np.ascontiguousarray(out.transpose(2, 0, 1)), kept


def make_batch(samples, flips, rng=None):
    """Input, heat, box and mask tensors of a batch. With `rng`, each image is also zoomed by a
    random factor in [0.7, 1.4] (log-uniform) and its brightness scaled by one in [0.7, 1.4]."""
    pw = padded(max(s[0].shape[2] for s in samples))
    ph = padded(max(s[0].shape[1] for s in samples))
    cw, ch = pw // STRIDE_PX, ph // STRIDE_PX
    inputs = np.zeros((len(samples), 3, ph, pw), np.float32)
    heats, boxes, masks = [], [], []
    for k, ((pixels, bxs), flip) in enumerate(zip(samples, flips)):
        _, h, w = pixels.shape
        img = pixels[:, :, ::-1] if flip else pixels
        if flip:
            bxs = [(c, w - x - bw, y, bw, bh) for c, x, y, bw, bh in bxs]
        values = img.astype(np.float32)
        if rng is not None:
            zoomed, bxs = rescaled(np.ascontiguousarray(img), bxs, math.exp(rng.uniform(math.log(0.7), math.log(1.4))), rng)
            values = np.clip(zoomed.astype(np.float32) * math.exp(rng.uniform(math.log(0.7), math.log(1.4))), 0, 255)
        inputs[k, :, :h, :w] = (values / 255.0 - INPUT_MEAN) / INPUT_SPREAD
        t = encode(bxs, cw, ch)
        heats.append(t[0])
        boxes.append(t[1])
        masks.append(t[2])
    return (torch.from_numpy(inputs), torch.from_numpy(np.stack(heats)), torch.from_numpy(np.stack(boxes)),
            torch.from_numpy(np.stack(masks)))


def loss_fn(heat_logits, box_out, heat, boxes, mask):
    """CenterNet's penalty-reduced focal loss and box L1, per object."""
    p = torch.sigmoid(heat_logits).clamp(1e-4, 1 - 1e-4)
    centre = (heat >= 1).float()
    objects = centre.sum().clamp(min=1)
    pos = (torch.log(p) * (1 - p) ** 2 * centre).sum()
    neg = (torch.log(1 - p) * p**2 * (1 - heat) ** 4).sum()
    heat_loss = -(pos + neg) / objects
    box_loss = ((box_out - boxes).abs() * mask).sum() / objects
    return heat_loss, box_loss


def learning_rate(peak, step, total):
    warm = max(min(300, total // 10), 1)
    if step < warm:
        return peak * (0.1 + 0.9 * step / warm)
    t = (step - warm) / max(total - warm, 1)
    return peak * (0.02 + 0.98 * 0.5 * (1 + math.cos(math.pi * t)))


def validate(weights, folder, scene_gen):
    """AP@0.5 and AP of the Rust detector over `weights` on a dataset folder (pycocotools)."""
    from pycocotools.coco import COCO
    from pycocotools.cocoeval import COCOeval

    folder = Path(folder)
    scores = []
    for ann in annotation_files(folder):
        coco = json.loads(ann.read_text())
        files = [str(folder / "images" / i["file_name"]) for i in coco["images"]]
        out = subprocess.run([scene_gen, "detect", "--json", "--weights", str(weights), *files],
                             check=True, capture_output=True, text=True).stdout
        ids = {str(folder / "images" / i["file_name"]): i["id"] for i in coco["images"]}
        dets = [dict(d, image_id=ids[d["file_name"]]) for d in json.loads(out)]
        with contextlib.redirect_stdout(io.StringIO()):
            gt = COCO(str(ann))
        if not dets:
            scores.append((0.0, 0.0, len(coco["images"])))
            continue
        with contextlib.redirect_stdout(io.StringIO()):
            ev = COCOeval(gt, gt.loadRes(dets), "bbox")
            ev.evaluate()
            ev.accumulate()
            ev.summarize()
        scores.append((ev.stats[1], ev.stats[0], len(coco["images"])))
    n = sum(s[2] for s in scores)
    return sum(s[0] * s[2] for s in scores) / n, sum(s[1] * s[2] for s in scores) / n


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", nargs="+", required=True)
    ap.add_argument("--validation")
    ap.add_argument("--out", required=True)
    ap.add_argument("--epochs", type=int, default=12)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--learning-rate", type=float, default=3e-3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--augment", action=argparse.BooleanOptionalAction, default=True,
                    help="random zoom (0.7-1.4x) and brightness (0.7-1.4x) besides the flips")
    ap.add_argument("--max-steps", type=int, default=0, help="stop after this many steps (timing runs)")
    ap.add_argument("--scene-gen", default="target/release/scene-gen")
    ap.add_argument("--init", help="start from these weights (a detector.safetensors) with the "
                    "normalisation frozen, as a warm restart of the schedule")
    args = ap.parse_args()
    for name in ("epochs", "batch", "threads"):
        if getattr(args, name) < 1:
            ap.error(f"--{name} must be at least 1")

    torch.manual_seed(args.seed)
    torch.set_num_threads(args.threads)
    torch.use_deterministic_algorithms(True)
    rng = np.random.default_rng(args.seed)
    samples = [s for folder in args.data for s in load_dataset(folder)]
    if args.validation:
        annotation_files(args.validation)
    model = Detector()
    if args.init:
        model.load_folded(args.init)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    params = sum(p.numel() for n, p in model.named_parameters() if n.startswith("convs"))
    print(f"{len(samples)} training images, {sum(len(s[1]) for s in samples)} objects; {params} parameters",
          flush=True)
    opt = torch.optim.AdamW(model.parameters(), lr=args.learning_rate, weight_decay=1e-4)
    steps_per_epoch = -(-len(samples) // args.batch)
    total = steps_per_epoch * args.epochs
    log = ["epoch\tstep\tloss\theat_loss\tbox_loss\tlearning_rate\telapsed_s"]
    val_log = ["epoch\tap50\tap\telapsed_s"]
    start = time.monotonic()
    step = 0
    for epoch in range(args.epochs):
        model.train()
        order = rng.permutation(len(samples))
        sums = [0.0, 0.0, 0]
        for b0 in range(0, len(order), args.batch):
            idx = order[b0 : b0 + args.batch]
            inputs, heat, boxes, mask = make_batch(
                [samples[i] for i in idx], rng.random(len(idx)) < 0.5, rng if args.augment else None
            )
            lr = learning_rate(args.learning_rate, step, total)
            for g in opt.param_groups:
                g["lr"] = lr
            heat_logits, box_out = model(inputs)
            hl, bl = loss_fn(heat_logits, box_out, heat, boxes, mask)
            opt.zero_grad()
            (hl + bl).backward()
            opt.step()
            sums = [sums[0] + hl.item(), sums[1] + bl.item(), sums[2] + 1]
            step += 1
            if step % 20 == 0 or step == total:
                h, bx = sums[0] / sums[2], sums[1] / sums[2]
                line = f"{epoch}\t{step}\t{h + bx:.4f}\t{h:.4f}\t{bx:.4f}\t{lr:.6f}\t{time.monotonic() - start:.0f}"
                print(line, flush=True)
                log.append(line)
                sums = [0.0, 0.0, 0]
            if args.max_steps and step >= args.max_steps:
                print(f"{step} steps in {time.monotonic() - start:.1f} s", flush=True)
                return
        weights = out / "detector.safetensors"
        save_file(model.folded(), str(weights))
        (out / "train_log.tsv").write_text("\n".join(log) + "\n")
        if args.validation:
            ap50, ap_all = validate(weights, args.validation, args.scene_gen)
            line = f"{epoch}\t{ap50:.4f}\t{ap_all:.4f}\t{time.monotonic() - start:.0f}"
            print(f"validation {line}", flush=True)
            val_log.append(line)
            (out / "validation.tsv").write_text("\n".join(val_log) + "\n")


if __name__ == "__main__":
    main()
