"""Called by check_emva.sh: `scene-gen calibrate` against the EMVA 1288 reference implementation
(the `emva1288` package) on data sets made by that package's own camera simulator."""

import json
import logging
import os
import subprocess
import sys
import tempfile

import cv2
import numpy as np

# emva1288 1.0.2 predates NumPy 2, which removed np.asfarray and np.int: restore both, as
# NumPy 1 defined them, before the package is imported.
if not hasattr(np, "asfarray"):
    np.asfarray = lambda a, dtype=np.float64: np.asarray(a, dtype=dtype)
if not hasattr(np, "int"):
    np.int = int

from emva1288.camera.dataset_generator import DatasetGenerator  # noqa: E402
from emva1288.process import Data1288, LoadImageData, ParseEmvaDescriptorFile, Results1288  # noqa: E402

TOLERANCE = 0.03
# (bit depth, simulator seed, dark noise variance in e-^2): every ADC depth, and an 8-bit
# case whose dark noise is quantization-limited (below 0.24 DN^2).
CASES = [(8, 1, 10.0), (8, 2, 0.5), (8, 3, 40.0), (10, 4, 2.0), (10, 5, 10.0), (12, 6, 100.0), (12, 7, 10.0)]


def reference(descriptor: str) -> dict:
    quiet = logging.ERROR
    parsed = ParseEmvaDescriptorFile(descriptor, loglevel=quiet)
    data = Data1288(LoadImageData(parsed.images, loglevel=quiet).data, loglevel=quiet)
    results = Results1288(data.data, loglevel=quiet)
    return {"K": results.K, "sigma_d": results.sigma_d, "QE": results.QE / 100.0}


def as_png(folder: str, descriptor: str) -> str:
    """A copy of the descriptor over 16-bit PNGs of its images: above 8 bits the simulator
    writes 32-bit signed TIFFs, which scene-gen does not read; the values are the same."""
    with open(descriptor) as f:
        text = f.read()
    for name in os.listdir(os.path.join(folder, "images")):
        if name.endswith(".tiff"):
            path = os.path.join(folder, "images", name)
            cv2.imwrite(path[:-5] + ".png", cv2.imread(path, cv2.IMREAD_UNCHANGED).astype(np.uint16))
    copy = os.path.join(folder, "descriptor_png.txt")
    with open(copy, "w") as f:
        f.write(text.replace(".tiff", ".png"))
    return copy


def ours(binary: str, descriptor: str) -> dict:
    done = subprocess.run([binary, "calibrate", descriptor, "--json"], capture_output=True, text=True, check=True)
    r = json.loads(done.stdout)[0]
    return {"K": r["system_gain_k_dn_per_e"], "sigma_d": r["dark_noise_e"], "QE": r["quantum_efficiency"]}


def main(binary: str) -> int:
    failures = []
    print(f"{'bits':>4} {'seed':>4} {'dark e2':>7}  " + "  ".join(f"{k:>22s}" for k in ("K (DN/e-)", "sigma_d (e-)", "QE")))
    for bits, seed, dark_var in CASES:
        with tempfile.TemporaryDirectory() as folder:
            generated = DatasetGenerator(
                steps=20, L=4, outdir=folder, width=64, height=48, bit_depth=bits, seed=seed,
                sigma2_dark_0=dark_var, image_format="png" if bits == 8 else "tiff",
            )
            ref = reference(generated.descriptor_path)
            descriptor = generated.descriptor_path if bits == 8 else as_png(folder, generated.descriptor_path)
            got = ours(binary, descriptor)
        cells = []
        for key in ("K", "sigma_d", "QE"):
            rel = got[key] / ref[key] - 1.0
            cells.append(f"{got[key]:8.4f} vs {ref[key]:8.4f} {100 * rel:+5.1f}%")
            if abs(rel) > TOLERANCE:
                failures.append(f"{bits}-bit seed {seed}: {key} {got[key]:.4f}, reference {ref[key]:.4f}")
        print(f"{bits:>4} {seed:>4} {dark_var:>7}  " + "  ".join(cells))
    for f in failures:
        print("FAIL", f)
    print("check_emva:", "FAILED" if failures else f"ok ({len(CASES)} data sets within {100 * TOLERANCE:.0f} %)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
