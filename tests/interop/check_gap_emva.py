"""Called by check_gap_emva.sh: `scene-gen gap` on EMVA 1288 data sets made by the reference
implementation's camera simulator (the `emva1288` package), code this project did not write,
with effects hidden in them.

Every simulated camera has a black offset (the package picks it by the EMVA rule) and dark
current (30 e-/s at 30 C, about 15 e-/s at the simulated 22 C): `black_level` and
`dark_current` are expected everywhere, and `saturation` where the full well (15,000 e-)
clips below the ADC's top (at 12 bits; at 8 and 10 the ADC clips first, which the linear model
already holds). The simulator adds a uniform noise one DN wide before
it rounds, which `gap` names `quantization` (dithered rounding) where it shows, that is where
the dark noise is below about half a DN; naming it or not is right either way. On top, each
case hides nothing or some of: PRNU (a 2 % Gaussian gain map), DSNU (a 3 e- half-normal offset
map), hot pixels (one pixel in 2,000 offset by 200-2,000 e-).

Where the generator puts the spatial stack above the full well (at 12 bits its stack sits at
half the ADC range, over the 1,501 DN plateau), a PRNU leaves no trace and is not expected.
Gates: the named effects are exactly the expected ones in at least 90 % of the 16
hidden-effect cases (8, 10 and 12 bits at 160x120, and one 640x480 set, above the size where
`gap` screens candidates on the top rows), and a clean set gets a name outside the expected
ones in at most 5 % of 30 seeds (8, 10 and 12 bits in turn). Measured: 15 of 16 exact; the
miss is the 640x480 set, whose black level is left tentative beside unexplained misfit; no
false names on the 30 clean sets. The gate holds what is reached, so that it fails on any loss.
Unexplained misfit is counted and printed, not gated: the simulator's physics differs from the
library's where it dithers its rounding after the full-well clip (12 bits) and, by the pattern
of its dark series, where it clips charge at zero electrons before the gain (8 bits).
"""

import json
import logging
import os
import subprocess
import sys
import tempfile
import time

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from check_emva import as_png  # noqa: E402  (also restores what emva1288 1.0.2 needs of NumPy)

from emva1288.camera.dataset_generator import DatasetGenerator  # noqa: E402

EXPECTED = {"black_level", "dark_current"}
OPTIONAL = {"quantization"}
HIDDEN = ["none", "prnu", "dsnu", "hot_pixels", "dsnu+prnu"]
NAMING_CASES = [(bits, 160, 120, effect, 10 * bits + i) for bits in (8, 10, 12) for i, effect in enumerate(HIDDEN)]
NAMING_CASES.append((8, 640, 480, "dsnu+prnu", 5))
CLEAN_SEEDS = range(1000, 1030)
MIN_EXACT = 0.90
MAX_FALSE = 0.05


def hidden_maps(effect: str, width: int, height: int, seed: int) -> dict:
    """The camera simulator's `prnu` and `dsnu` arguments that hide `effect`."""
    rng = np.random.default_rng(seed)
    maps = {}
    if "prnu" in effect:
        maps["prnu"] = 1.0 + rng.normal(0.0, 0.02, (height, width))
    if "dsnu" in effect:
        maps["dsnu"] = np.abs(rng.normal(0.0, 3.0, (height, width)))
    if effect == "hot_pixels":
        d = np.zeros((height, width))
        hot = rng.choice(height * width, max(3, height * width // 2000), replace=False)
        d.flat[hot] = rng.uniform(200.0, 2000.0, hot.size)
        maps["dsnu"] = d
    return maps


def bright_stack_saturated(descriptor: str) -> bool:
    """Whether the first frame of the descriptor's bright spatial stack (a bright block of more
    than two images) sits on the saturation plateau: 95 % of its pixels within one DN of its
    median."""
    blocks, current = [], None
    with open(descriptor) as f:
        for line in f:
            parts = line.split()
            if parts and parts[0] in ("b", "d"):
                current = {"bright": parts[0] == "b", "images": []}
                blocks.append(current)
            elif parts and parts[0] == "i" and current is not None:
                current["images"].append(parts[1])
    stacks = [b for b in blocks if b["bright"] and len(b["images"]) > 2]
    if not stacks:
        return False
    # The generator writes Windows separators.
    path = os.path.join(os.path.dirname(descriptor), stacks[0]["images"][0].replace("\\", "/"))
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None:
        return False
    # On the plateau only the rounding dither spreads the pixels, by one DN; shot noise at half
    # range spreads them by more than one DN even at 8 bits.
    return bool((np.abs(img.astype(np.float64) - np.median(img)) <= 1.0).mean() > 0.95)


def write_set(folder: str, bits: int, width: int, height: int, effect: str, seed: int):
    """One case's data set written to `folder` by the reference simulator: its descriptor (with
    PNG images) and the simulated camera."""
    generated = DatasetGenerator(
        steps=20, L=8, outdir=folder, width=width, height=height, bit_depth=bits, seed=seed,
        image_format="png" if bits == 8 else "tiff", **hidden_maps(effect, width, height, seed),
    )
    descriptor = generated.descriptor_path if bits == 8 else as_png(folder, generated.descriptor_path)
    return descriptor, generated.cam


def run_case(binary: str, bits: int, width: int, height: int, effect: str, seed: int) -> tuple[set, set, float, list]:
    """The effects `gap` names, the effects the simulated camera has, gap's seconds and the
    families it reports unexplained."""
    with tempfile.TemporaryDirectory() as folder:
        descriptor, cam = write_set(folder, bits, width, height, effect, seed)
        expected = EXPECTED | (set() if effect == "none" else set(effect.split("+")))
        if cam.K * cam._u_esat + cam.blackoffset < cam.img_max:
            expected.add("saturation")
        if bright_stack_saturated(descriptor):
            # The generator puts the spatial stack at half the ADC range, above a full well
            # that clips lower: every pixel sits on the plateau, and a gain pattern leaves no
            # trace in the data.
            expected.discard("prnu")
        t0 = time.perf_counter()
        done = subprocess.run([binary, "gap", descriptor, "--json", "--quiet", "--out", os.path.join(folder, "gap")],
                              capture_output=True, text=True)
        seconds = time.perf_counter() - t0
        if done.returncode != 0:
            raise SystemExit(f"gap failed on {bits}-bit {width}x{height} {effect} seed {seed}:\n{done.stderr}")
        summary = json.loads(done.stdout)
        return set(summary["named"]), expected, seconds, [u["family"] for u in summary["unexplained"]]


def main(binary: str) -> int:
    logging.disable(logging.WARNING)
    print(f"{'bits':>4} {'size':>8} {'hidden':<10} {'seed':>4} {'time':>6}  named")
    exact, misses, alarms, clean_alarms = 0, [], 0, 0
    for bits, width, height, effect, seed in NAMING_CASES:
        named, expected, seconds, unexplained = run_case(binary, bits, width, height, effect, seed)
        ok = named - OPTIONAL == expected
        alarms += bool(unexplained)
        exact += ok
        if not ok:
            misses.append(f"{bits}-bit {width}x{height} {effect} seed {seed}: {sorted(named)}")
        print(f"{bits:>4} {width}x{height:<4} {effect:<10} {seed:>4} {seconds:5.1f}s  {sorted(named)}"
              f"{'' if ok else '  MISS'}{'  unexplained ' + str(unexplained) if unexplained else ''}")
    false_names = 0
    for i, seed in enumerate(CLEAN_SEEDS):
        bits = (8, 10, 12)[i % 3]
        named, expected, seconds, unexplained = run_case(binary, bits, 160, 120, "none", seed)
        extra = named - expected - OPTIONAL
        clean_alarms += bool(unexplained)
        false_names += bool(extra)
        print(f"{bits:>4} 160x120  clean      {seed:>4} {seconds:5.1f}s  {sorted(named)}"
              f"{'  FALSE ' + str(sorted(extra)) if extra else ''}{'' if expected <= named else '  (missed some)'}"
              f"{'  unexplained ' + str(unexplained) if unexplained else ''}")
    exact_rate = exact / len(NAMING_CASES)
    false_rate = false_names / len(CLEAN_SEEDS)
    print(f"named exactly: {exact} of {len(NAMING_CASES)} ({100 * exact_rate:.0f} %, gate {100 * MIN_EXACT:.0f} %)")
    print(f"false names on clean sets: {false_names} of {len(CLEAN_SEEDS)} ({100 * false_rate:.1f} %, "
          f"gate {100 * MAX_FALSE:.0f} %)")
    print(f"unexplained misfit reported: {alarms} of {len(NAMING_CASES)} hidden-effect sets, {clean_alarms} of "
          f"{len(CLEAN_SEEDS)} clean sets (where the simulator's physics differs from the library's)")
    for m in misses:
        print("miss:", m)
    failed = exact_rate < MIN_EXACT or false_rate > MAX_FALSE
    print("check_gap_emva:", "FAILED" if failed else "ok")
    return 1 if failed else 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--write-set":
        if len(sys.argv) != 8:
            print("usage: check_gap_emva.py --write-set DIR BITS WIDTH HEIGHT EFFECT SEED", file=sys.stderr)
            sys.exit(2)
        # One case's set kept for timing by hand: --write-set DIR BITS WIDTH HEIGHT EFFECT SEED
        # prints its descriptor (docs/BENCHMARKS.md).
        logging.disable(logging.WARNING)
        out, bits, width, height, effect, seed = sys.argv[2:]
        os.makedirs(out, exist_ok=True)
        print(write_set(out, int(bits), int(width), int(height), effect, int(seed))[0])
        sys.exit(0)
    sys.exit(main(sys.argv[1]))
