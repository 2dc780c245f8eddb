"""Called by check_demosaic.sh: PSNR of `scene-gen isp --only-demosaic` beside OpenCV."""

import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np
import skimage.data

# The colour photographs bundled with scikit-image (no download).
PHOTOGRAPHS = ["astronaut", "chelsea", "coffee", "rocket", "immunohistochemistry", "hubble_deep_field"]
METHODS = ["bilinear", "malvar", "directional"]
# OpenCV names a Bayer pattern by the second row's second and third pixels, so an RGGB
# mosaic is its "BayerBG" (OpenCV's documentation, "Color conversions", Bayer).
OPENCV = {
    "RGGB": (cv2.COLOR_BayerBG2RGB, cv2.COLOR_BayerBG2RGB_EA),
    "BGGR": (cv2.COLOR_BayerRG2RGB, cv2.COLOR_BayerRG2RGB_EA),
    "GRBG": (cv2.COLOR_BayerGB2RGB, cv2.COLOR_BayerGB2RGB_EA),
    "GBRG": (cv2.COLOR_BayerGR2RGB, cv2.COLOR_BayerGR2RGB_EA),
}
BORDER = 2  # OpenCV's conversions treat the outermost pixels coarsely; both sides skip them.


def mosaic(rgb: np.ndarray, pattern: str) -> np.ndarray:
    channel = {"R": 0, "G": 1, "B": 2}
    out = np.zeros(rgb.shape[:2], dtype=np.uint8)
    for k, letter in enumerate(pattern):
        dy, dx = divmod(k, 2)
        out[dy::2, dx::2] = rgb[dy::2, dx::2, channel[letter]]
    return out


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    a = a[BORDER:-BORDER, BORDER:-BORDER].astype(np.float64)
    b = b[BORDER:-BORDER, BORDER:-BORDER].astype(np.float64)
    return float(10 * np.log10(255.0**2 / np.mean((a - b) ** 2)))


def ours(binary: str, raw: np.ndarray, pattern: str, method: str, folder: Path) -> np.ndarray:
    raw_path, out_path = folder / "raw.png", folder / f"{method}.png"
    cv2.imwrite(str(raw_path), raw)
    subprocess.run(
        [binary, "isp", str(raw_path), "--pattern", pattern, "--demosaic", method, "--only-demosaic", "--out", str(out_path)],
        check=True,
    )
    return cv2.cvtColor(cv2.imread(str(out_path), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)


def main(binary: str) -> int:
    failures = []
    print(f"{'photograph':22s} {'CFA':4s} {'cv bilinear':>11s} {'cv EA':>6s} " + " ".join(f"{m:>11s}" for m in METHODS))
    with tempfile.TemporaryDirectory() as tmp:
        for i, name in enumerate(PHOTOGRAPHS):
            rgb = getattr(skimage.data, name)()[..., :3]
            pattern = list(OPENCV)[i % 4]
            raw = mosaic(rgb, pattern)
            bilinear_code, ea_code = OPENCV[pattern]
            cv_bilinear = psnr(cv2.cvtColor(raw, bilinear_code), rgb)
            cv_ea = psnr(cv2.cvtColor(raw, ea_code), rgb)
            scores = {m: psnr(ours(binary, raw, pattern, m, Path(tmp)), rgb) for m in METHODS}
            print(f"{name:22s} {pattern:4s} {cv_bilinear:11.2f} {cv_ea:6.2f} " + " ".join(f"{scores[m]:11.2f}" for m in METHODS))
            if abs(scores["bilinear"] - cv_bilinear) > 0.5:
                failures.append(f"{name}: our bilinear {scores['bilinear']:.2f} dB, OpenCV's {cv_bilinear:.2f} dB")
            best = scores["directional"]  # the ISP default
            if best < cv_ea + 1.0:
                failures.append(f"{name}: directional {best:.2f} dB, not 1 dB above OpenCV EA {cv_ea:.2f} dB")
    for f in failures:
        print("FAIL", f)
    print("check_demosaic:", "FAILED" if failures else f"ok ({len(PHOTOGRAPHS)} photographs, all four CFA patterns)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
