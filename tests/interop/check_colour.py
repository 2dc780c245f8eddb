"""CIEDE2000 of the simulated ColorChecker, recomputed with scikit-image (see check_colour.sh)."""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image
from skimage.color import deltaE_ciede2000, rgb2lab

CAMERAS = ["IMX172", "IMX174", "IMX250", "PYTHON300"]
DAY_MEAN_GATE = 3.0
AGREEMENT = 0.05


def lab_of(srgb8):
    """CIELAB (D65) of 8-bit sRGB triples, as scikit-image converts them."""
    return rgb2lab(np.asarray(srgb8, dtype=np.float64).reshape(-1, 1, 3) / 255.0).reshape(-1, 3)


def check_camera(bin_path, model, out):
    camera = f"{model},noise=off,vignetting=false"
    subprocess.run(
        [bin_path, "target", "colour", "--camera", camera, "--lighting", "both", "--json", "--out", str(out)],
        check=True,
        capture_output=True,
    )
    report = json.loads((out / "colour_chart.json").read_text())
    rows = []
    for lighting in report["lightings"]:
        name = lighting["lighting"]
        image = np.asarray(Image.open(out / f"colour_chart_{name}.png").convert("RGB"), dtype=np.float64)
        patches = lighting["patches"]
        measured = []
        for p in patches:
            x0, y0, x1, y1 = p["region_px"]
            measured.append(image[y0:y1, x0:x1].reshape(-1, 3).mean(axis=0))
        reference = [p["reference_srgb"] for p in patches]
        theirs = deltaE_ciede2000(lab_of(reference), lab_of(measured))
        ours = np.array([p["delta_e_2000"] for p in patches])
        worst = float(np.max(np.abs(theirs - ours)))
        assert worst <= AGREEMENT, f"{model} {name}: our CIEDE2000 differs from scikit-image's by {worst:.3f}"
        mean = float(theirs.mean())
        rows.append((model, name, mean, float(theirs.max()), worst))
        if name == "day":
            assert mean <= DAY_MEAN_GATE, f"{model} day: mean CIEDE2000 {mean:.2f} > {DAY_MEAN_GATE}"
    return rows


def main():
    bin_path = sys.argv[1]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for model in CAMERAS:
            rows += check_camera(bin_path, model, Path(tmp) / model)
    print("camera     lighting  mean dE00  max dE00  |ours - skimage|")
    for model, name, mean, worst_patch, agreement in rows:
        print(f"{model:<10} {name:<8} {mean:>9.2f} {worst_patch:>9.2f} {agreement:>16.4f}")
    print("colour check: ok")


if __name__ == "__main__":
    main()
