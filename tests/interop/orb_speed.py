"""ORB speed, scene-gen vs OpenCV on one thread, same images, same run (a benchmark, not a test).

    cargo build --release --example orb_bench && .venv/bin/python tests/interop/orb_speed.py [NAME]
    .venv/bin/python tests/interop/orb_speed.py A.png B.png [REPS]

With a scikit-image photograph NAME (default astronaut), writes it grey at 640x480 and a
rotated, shifted copy, times cv2.ORB_create(2000).detectAndCompute and BFMatcher(NORM_HAMMING,
crossCheck=True).match (median of REPS runs, cv2.setNumThreads(1)), runs
target/release/examples/orb_bench on the same files and prints the ratios (ours / OpenCV; below
1 is faster). Given two image files instead (e.g. the day images of `scene-gen render` at a
sensor's native size), times extraction on both sides on the first, read as grey, with the
time per pixel. Both sides report the median and the fastest run; on a shared, loaded machine
the fastest run is the steadier figure. An unreadable image or a bad REPS exits with status 2.
"""

import json
import os
import subprocess
import sys
import tempfile
import time

import cv2
import numpy as np
import skimage.data

W, H, N, REPS = 640, 480, 2000, 30
BENCH = os.environ.get("ORB_BENCH_BIN", "target/release/examples/orb_bench")


def times_ms(f, reps=REPS):
    f()
    t = []
    for _ in range(reps):
        s = time.perf_counter()
        f()
        t.append((time.perf_counter() - s) * 1e3)
    return float(np.median(t)), float(np.min(t))


def main():
    cv2.setNumThreads(1)
    if len(sys.argv) > 2:
        reps = sys.argv[3] if len(sys.argv) > 3 else "10"
        if not reps.isdigit() or int(reps) < 1:
            fail(f"REPS {reps!r}: expected a whole number of runs, at least 1")
        return compare(sys.argv[1], sys.argv[2], int(reps))
    name = sys.argv[1] if len(sys.argv) > 1 else "astronaut"
    img = getattr(skimage.data, name)()
    if img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    a = cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA)
    m = cv2.getRotationMatrix2D((W / 2, H / 2), 4.0, 0.97)
    m[:, 2] += (9.0, -6.0)
    b = cv2.warpAffine(a, m, (W, H), borderMode=cv2.BORDER_REFLECT_101)
    tmp = tempfile.mkdtemp(prefix="orb_speed_")
    pa, pb = os.path.join(tmp, "a.png"), os.path.join(tmp, "b.png")
    cv2.imwrite(pa, a)
    cv2.imwrite(pb, b)

    orb = cv2.ORB_create(nfeatures=N)
    ka, da = orb.detectAndCompute(a, None)
    kb, db = orb.detectAndCompute(b, None)
    bf = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True)
    cv_extract = times_ms(lambda: orb.detectAndCompute(a, None))
    cv_match = times_ms(lambda: bf.match(da, db))

    res = subprocess.run([BENCH, pa, pb, str(N), str(REPS)], capture_output=True, text=True, check=True)
    ours = json.loads(res.stdout)
    print(f"OpenCV {cv2.__version__} (1 thread) vs scene-gen, {name} {W}x{H}, {N} features, {REPS} runs (median / fastest)")
    print(f"  keypoints        opencv {len(ka)}/{len(kb)}  ours {ours['keypoints_a']}/{ours['keypoints_b']}")
    for label, cv, key in [("extraction", cv_extract, "extract"), (f"match {len(da)}x{len(db)}", cv_match, "match")]:
        med, best = ours[key + "_ms"], ours[key + "_min_ms"]
        print(
            f"  {label:16s} opencv {cv[0]:7.2f} / {cv[1]:7.2f} ms  ours {med:7.2f} / {best:7.2f} ms  "
            f"ratio {med / cv[0]:.2f} / {best / cv[1]:.2f}"
        )
    print(f"  match + RANSAC   ours {ours['match_ransac_ms']:7.2f} ms (median)")


def fail(message):
    """Bad input: the message on stderr, exit status 2."""
    print(f"orb_speed: {message}", file=sys.stderr)
    sys.exit(2)


def compare(pa, pb, reps):
    """Both extractors on two given image files."""
    a, b = cv2.imread(pa, cv2.IMREAD_GRAYSCALE), cv2.imread(pb, cv2.IMREAD_GRAYSCALE)
    for path, img in ((pa, a), (pb, b)):
        if img is None:
            fail(f"cannot read {path} as an image")
    orb = cv2.ORB_create(nfeatures=N)
    cv_extract = times_ms(lambda: orb.detectAndCompute(a, None), reps)
    res = subprocess.run([BENCH, pa, pb, str(N), str(reps)], capture_output=True, text=True, check=True)
    ours = json.loads(res.stdout)
    pixels = a.shape[0] * a.shape[1]
    med, best = ours["extract_ms"], ours["extract_min_ms"]
    print(f"OpenCV {cv2.__version__} (1 thread) vs scene-gen, {pa}: {a.shape[1]}x{a.shape[0]}, {N} features, {reps} runs")
    print(
        f"  extraction  opencv {cv_extract[0]:7.2f} / {cv_extract[1]:7.2f} ms ({cv_extract[1] * 1e6 / pixels:.1f} ns/px)  "
        f"ours {med:7.2f} / {best:7.2f} ms ({best * 1e6 / pixels:.1f} ns/px)  ratio {med / cv_extract[0]:.2f} / {best / cv_extract[1]:.2f}"
    )
    print(f"  match + RANSAC   ours {ours['match_ransac_ms']:7.2f} ms (median)")


if __name__ == "__main__":
    main()
