"""Draws scene-gen's test chart from its layout JSON alone and writes a "photograph" of it (a
16-bit PNG of DN) for `scene-gen target gap`. No pixel comes from scene-gen's renderer or
sensor model: OpenCV draws the patches and the texture blocks, scikit-image the slanted edges,
OpenCV applies the optics, and numpy draws the noise.

    draw_chart.py LAYOUT.json OUT.png [--seed N] [--lens SIGMA] [--motion LENGTH]
                  [--falloff HALF_ANGLE_DEG] [--gamma G] [--sharpen AMOUNT]

What the layout gives (`scene-gen/target-layout/1`): the boxes and reflectances of the grey
patches, each edge's line and its two reflectances, the texture blocks' reflectances, the chart's
size and distance (so the field angle of every pixel), and `sensor_record`: electrons per unit
reflectance on the axis, whether the lens vignettes as cos^4, dark electrons, system gain, the
output with no charge, read noise in DN and the full well.

The chart is rasterised 16 times finer than the sensor with `cv2.rectangle` and
`skimage.draw.polygon` (which fills the fine pixels whose centres lie inside; `cv2.fillPoly`
also fills those its outline touches, which moves a slanted edge by a fraction of a fine
pixel) and averaged down with `cv2.resize(INTER_AREA)`, so every pixel holds the mean
reflectance of its area to 1/256. Effects, in the order light meets them:

* `--falloff D`: an extra cos^4 shading reaching the field angle D at the corners (numpy);
* `--lens S`: a Gaussian PSF of sigma S px (`cv2.GaussianBlur`);
* `--motion L`: a horizontal line PSF L px long (`cv2.filter2D`);
* `--sharpen A`: an unsharp mask, `s + A (s - GaussianBlur(s, 1 px))`, as a camera's ISP
  sharpens; it narrows edges below what any lens can do (outside the loop's library);
* then Poisson electrons, clipped at the full well, Gaussian read noise in DN, and
* `--gamma G`: a tone curve on the output above black, `max ((y - black) / max)^G`, before
  rounding (outside the loop's library).
"""

import argparse
import json
import sys

import cv2
import numpy as np
import skimage.draw

SUPERSAMPLE = 16


def canvas_coordinate(u):
    """A continuous pixel coordinate (pixel i spans [i, i+1)) on the fine canvas, whose pixel
    centres sit at integers (OpenCV's and scikit-image's convention)."""
    return u * SUPERSAMPLE - 0.5


def fill_box(canvas, box, value):
    s = SUPERSAMPLE
    cv2.rectangle(canvas, (box["x0"] * s, box["y0"] * s), (box["x1"] * s - 1, box["y1"] * s - 1), float(value), -1)


def bright_side(edge):
    """The polygon of the edge's cell on its bright side: the cell's corners clipped by the
    half-plane `(p - point) . normal > 0` (one Sutherland-Hodgman pass)."""
    c = edge["cell"]
    corners = [(c["x0"], c["y0"]), (c["x1"], c["y0"]), (c["x1"], c["y1"]), (c["x0"], c["y1"])]
    (px, py), (nx, ny) = edge["point"], edge["normal"]
    side = [(x - px) * nx + (y - py) * ny for x, y in corners]
    poly = []
    for i, (a, da) in enumerate(zip(corners, side)):
        b, db = corners[(i + 1) % 4], side[(i + 1) % 4]
        if da > 0:
            poly.append(a)
        if (da > 0) != (db > 0):
            t = da / (da - db)
            poly.append((a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])))
    return poly


def reflectance(layout):
    w, h, s = layout["width_px"], layout["height_px"], SUPERSAMPLE
    canvas = np.zeros((h * s, w * s), np.float32)
    for p in layout["patches"]:
        fill_box(canvas, p["cell"], p["reflectance"])
    for e in layout["edges"]:
        fill_box(canvas, e["cell"], e["dark"])
        poly = bright_side(e)
        rows = np.array([canvas_coordinate(y) for _, y in poly])
        cols = np.array([canvas_coordinate(x) for x, _ in poly])
        rr, cc = skimage.draw.polygon(rows, cols, shape=canvas.shape)
        canvas[rr, cc] = e["bright"]
    t, b = layout["texture"], layout["texture_block_px"]
    across = -(-(t["x1"] - t["x0"]) // b)
    for i, rho in enumerate(layout["texture_reflectances"]):
        x0, y0 = t["x0"] + (i % across) * b, t["y0"] + (i // across) * b
        box = {"x0": x0, "y0": y0, "x1": min(x0 + b, t["x1"]), "y1": min(y0 + b, t["y1"])}
        fill_box(canvas, box, rho)
    return cv2.resize(canvas, (w, h), interpolation=cv2.INTER_AREA).astype(np.float64)


def cos4(layout, half_angle_deg=None):
    """cos^4 of each pixel centre's field angle; with `half_angle_deg`, of a lens whose corners
    see that angle instead of the chart's own geometry."""
    w, h = layout["width_px"], layout["height_px"]
    yy, xx = np.mgrid[0:h, 0:w]
    dx, dy = xx + 0.5 - w / 2, yy + 0.5 - h / 2
    if half_angle_deg is None:
        scale_x = layout["chart_width_m"] / w / layout["distance_m"]
        scale_y = layout["chart_height_m"] / h / layout["distance_m"]
        tan2 = (dx * scale_x) ** 2 + (dy * scale_y) ** 2
    else:
        r = np.hypot(dx, dy) / np.hypot(w / 2, h / 2)
        tan2 = (r * np.tan(np.radians(half_angle_deg))) ** 2
    return (1.0 / (1.0 + tan2)) ** 2


def optics(signal, layout, falloff=None, lens=None, motion=None):
    """`signal` through an extra cos^4 fall-off reaching `falloff` degrees at the corners, a
    Gaussian PSF of sigma `lens` px (`cv2.GaussianBlur`) and a horizontal line PSF `motion` px
    long (`cv2.filter2D`), each where given."""
    if falloff is not None:
        signal = signal * cos4(layout, falloff)
    if lens is not None:
        signal = cv2.GaussianBlur(signal, (0, 0), lens, borderType=cv2.BORDER_REPLICATE)
    if motion is not None:
        k = np.zeros((motion, motion), np.float64)
        k[motion // 2, :] = 1.0 / motion
        signal = cv2.filter2D(signal, -1, k, borderType=cv2.BORDER_REPLICATE)
    return signal


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("layout")
    ap.add_argument("out")
    ap.add_argument("--seed", type=int, default=1, help="seed of numpy's noise")
    ap.add_argument("--lens", type=float, help="Gaussian PSF sigma, px")
    ap.add_argument("--motion", type=int, help="horizontal line PSF length, px")
    ap.add_argument("--falloff", type=float, help="extra cos^4 shading reaching this field angle at the corners, deg")
    ap.add_argument("--sharpen", type=float, help="unsharp-mask amount")
    ap.add_argument("--gamma", type=float, help="tone curve exponent on the output above black")
    a = ap.parse_args()

    try:
        with open(a.layout) as f:
            layout = json.load(f)
    except (OSError, ValueError) as e:
        print(f"draw_chart: {a.layout}: cannot read the layout: {e}", file=sys.stderr)
        return 2
    rec = layout.get("sensor_record")
    if not rec or not layout.get("texture_reflectances"):
        print(f"draw_chart: {a.layout}: no sensor_record or texture_reflectances (written by an older scene-gen?)",
              file=sys.stderr)
        return 2
    signal = rec["signal_e_per_reflectance"] * reflectance(layout)
    if rec["cos4_vignetting"]:
        signal *= cos4(layout)
    signal = optics(signal, layout, a.falloff, a.lens, a.motion)
    if a.sharpen is not None:
        signal = signal + a.sharpen * (signal - cv2.GaussianBlur(signal, (0, 0), 1.0, borderType=cv2.BORDER_REPLICATE))
        signal = np.maximum(signal, 0.0)

    rng = np.random.default_rng(a.seed)
    electrons = rng.poisson(signal + rec["dark_e"]).astype(np.float64)
    if rec["full_well_e"] is not None:
        electrons = np.minimum(electrons, rec["full_well_e"])
    black = rec["black_offset_dn"]
    y = black + rec["system_gain_dn_per_e"] * electrons + rng.normal(0.0, rec["read_noise_dn"], signal.shape)
    max_dn = 2 ** layout["bits"] - 1
    if a.gamma is not None:
        y = black + max_dn * (np.clip(y - black, 0.0, None) / max_dn) ** a.gamma
    dn = np.clip(np.rint(y), 0, max_dn).astype(np.uint16)
    if not cv2.imwrite(a.out, dn):
        print(f"draw_chart: cannot write {a.out}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
