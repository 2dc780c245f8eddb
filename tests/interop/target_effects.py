"""Applies optics effects to a simulated test chart with OpenCV and numpy, independently of
scene-gen's own effect code, and writes the "measured" 16-bit PNG for `scene-gen target gap`.

A lens blurs and shades the light before the sensor, so the effect is applied to the noiseless
render (`<stem>.mean.png`, DN x 16, written by `scene-gen target chart`); the render's own noise
realisation (noisy minus mean, from scene-gen's sensor model) is then carried over, rescaled to
the new signal level with an affine noise law `var = a + b * signal` that this script fits
itself to the chart's noise (a photon-transfer fit: read and quantisation noise in `a`, shot
noise in `b`).

    target_effects.py CHART.png LAYOUT.json OUT.png [--lens SIGMA] [--motion LENGTH]
                      [--falloff HALF_ANGLE_DEG] [--gamma G]

`--gamma` is a tone curve on the signal above black, `max (s / max)^G` (after the optics, with
the noise carried through it): an effect outside the loop's library, for the unexplained-misfit
check.
"""

import argparse
import json
import sys

import cv2
import numpy as np

# The chart drawer's optics, so both ways of making a test photograph blur and shade alike.
from draw_chart import optics


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("chart")
    ap.add_argument("layout")
    ap.add_argument("out")
    ap.add_argument("--lens", type=float, help="Gaussian PSF sigma, px (cv2.GaussianBlur)")
    ap.add_argument("--motion", type=int, help="horizontal line kernel length, px (cv2.filter2D)")
    ap.add_argument("--falloff", type=float, help="cos^4 fall-off reaching this field angle at the corners, deg")
    ap.add_argument("--gamma", type=float, help="tone curve exponent on the signal above black")
    a = ap.parse_args()

    layout = json.load(open(a.layout))
    noisy = cv2.imread(a.chart, cv2.IMREAD_UNCHANGED).astype(np.float64)
    mean_path = a.chart[: -len(".png")] + ".mean.png"
    # The noiseless render holds DN x 16 (scene_gen::target::chart::MEAN_PNG_SCALE).
    mean = cv2.imread(mean_path, cv2.IMREAD_UNCHANGED).astype(np.float64) / 16.0
    if noisy.shape != mean.shape or noisy.shape != (layout["height_px"], layout["width_px"]):
        print("target_effects: chart, mean and layout sizes differ", file=sys.stderr)
        return 1
    black = layout["black_level_dn"]
    max_dn = 2 ** layout["bits"] - 1
    signal = mean - black

    out = optics(signal, layout, a.falloff, a.lens, a.motion)

    noise = noisy - mean
    # Photon transfer of the render: noise variance against signal over 24 signal quantiles,
    # fitted with a straight line.
    edges = np.quantile(signal, np.linspace(0, 1, 25))
    xs, ys = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (signal >= lo) & (signal < hi)
        if sel.sum() > 100:
            xs.append(signal[sel].mean())
            ys.append(noise[sel].var())
    slope, icpt = np.polyfit(xs, ys, 1)
    var_old = np.clip(icpt + slope * signal, 1e-6, None)
    var_new = np.clip(icpt + slope * np.clip(out, 0, None), 1e-6, None)
    scale = np.sqrt(var_new / var_old)
    signal_out = out + noise * scale
    if a.gamma is not None:
        top = max_dn - black
        signal_out = top * (np.clip(signal_out, 0, None) / top) ** a.gamma
    measured = np.clip(np.rint(black + signal_out), 0, max_dn).astype(np.uint16)
    cv2.imwrite(a.out, measured)
    print(f"target_effects: {a.out} lens={a.lens} motion={a.motion} falloff={a.falloff} gamma={a.gamma} "
          f"(noise var = {icpt:.3f} + {slope:.5f} signal)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
