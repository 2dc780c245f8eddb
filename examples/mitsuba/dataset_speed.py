"""Dataset frames per second: `scene-gen dataset` against Mitsuba 3 rendering the same frames.

Run through examples/mitsuba/run_dataset_speed.sh (it builds scene-gen and sets
DRJIT_LIBLLVM_PATH); the house goes to Mitsuba as scene-gen's OBJ export, written to OUT/obj once
the options are checked. Both renderers make the same frames of one house, in one run:

* scene-gen: `scene-gen dataset` (day and night images through the camera model, depth,
  instance and class masks, normals, COCO labels), run twice, for 1 frame and for `--frames`
  frames: the difference over the extra frames is the time of a frame once the house is built
  (its walk, BVH and irradiance volume), and the whole run's frames per second is reported too.
* Mitsuba: the views of those frames (read back from the dataset's labels: intrinsics and
  camera-to-world), rendered with the `path` integrator at the same samples per pixel and
  each `--depths` (a path of depth 2 is direct light alone; 8 and more is the converged
  multi-bounce light scene-gen's irradiance volume stands for), by day (window and sun
  emitters) and by night, plus one `aov` pass at 1 spp for depth, shading normal and shape
  index (the masks' source). Its images stay radiance: no sensor, no files. The scenes are
  loaded once; the first frame, which pays Dr.Jit's kernel compilation, is reported apart and
  left out of the per-frame time.

Reported: seconds per frame and frames per second of each, and scene-gen's speed-up
(Mitsuba's seconds per frame over scene-gen's), as one JSON line per case and a table.
"""

import argparse
import glob
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant("llvm_ad_rgb")

from gi_compare import house_shapes, light_entries  # noqa: E402


def view_sensor(view, width, height, spp):
    """A Mitsuba perspective sensor for a dataset frame's `view` (OpenCV axes, pinhole K)."""
    k = np.asarray(view["K"], dtype=np.float64)
    c2w = np.asarray(view["camera_to_world"], dtype=np.float64)
    pos, down, forward = c2w[:3, 3], c2w[:3, 1], c2w[:3, 2]
    hfov = np.degrees(2.0 * np.arctan(0.5 * width / k[0, 0]))
    return mi.load_dict({
        "type": "perspective",
        "fov": float(hfov),
        "fov_axis": "x",
        "near_clip": 1e-3,
        "far_clip": 1e4,
        "to_world": mi.ScalarTransform4f().look_at(origin=pos.tolist(), target=(pos + forward).tolist(),
                                                   up=(-down).tolist()),
        "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                 "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": spp},
    })


def run_scene_gen(binary, args, frames, out):
    """Wall seconds of `scene-gen dataset` for `frames` frames into a fresh folder `out` (a
    dataset left there would be resumed, not rendered, so it is removed first)."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [binary, "dataset", "--quiet", "--camera", args.camera, "--seeds", f"{args.seed}..{args.seed + 1}",
           "--frames", str(frames), "--quality", args.quality, "--out", out]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def frame_views(dataset):
    """(width, height, view) of every frame of a dataset, in pose order."""
    views = []
    for path in sorted(glob.glob(os.path.join(dataset, "labels", "*", "pose_*.json"))):
        labels = json.load(open(path))
        view = {"K": labels["K"], "camera_to_world": labels["camera_to_world"]}
        views.append((labels["width"], labels["height"], view))
    return views


def time_mitsuba(shapes, lights, views, spp, depth):
    """(first frame s, mean s of the others) of Mitsuba's day + night + AOV renders per view."""
    def scene(integrator, emitters):
        return mi.load_dict({"type": "scene", "integrator": integrator, **shapes, **emitters})

    path = {"type": "path", "max_depth": depth, "rr_depth": depth}
    scenes = [
        (scene(path, light_entries(lights, "day", {"rect", "point", "directional"})), spp),
        (scene(path, light_entries(lights, "night", {"point", "rect", "directional"})), spp),
        (scene({"type": "aov", "aovs": "dd:depth,nn:sh_normal,si:shape_index"}, {}), 1),
    ]
    times = []
    for width, height, view in views:
        t0 = time.perf_counter()
        for s, n in scenes:
            img = mi.render(s, sensor=view_sensor(view, width, height, n), spp=n, seed=len(times))
            dr.eval(img)
            np.asarray(img)  # the image on the host, as a dataset writer would need it
        times.append(time.perf_counter() - t0)
    return times[0], float(np.mean(times[1:])) if len(times) > 1 else times[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", required=True, help="the scene-gen binary")
    ap.add_argument("--out", required=True)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--camera", default="IMX273,focal_mm=3")
    ap.add_argument("--frames", type=int, default=9)
    ap.add_argument("--quality", default="evaluator", choices=["evaluator", "preview", "standard", "high"])
    ap.add_argument("--depths", default="2,8", help="Mitsuba path depths, comma-separated")
    args = ap.parse_args()
    if args.frames < 3:
        ap.error("--frames must be at least 3 (one to build the house, one to compile kernels)")
    try:
        depths = [int(d) for d in args.depths.split(",")]
    except ValueError:
        ap.error(f"--depths '{args.depths}': expected whole numbers, comma-separated")
    if not os.access(args.bin, os.X_OK):
        ap.error(f"--bin {args.bin}: not an executable")
    # Camera samples per pixel of each preset (RenderSettings: samples_per_axis squared).
    spp = {"evaluator": 1, "preview": 1, "standard": 4, "high": 16}[args.quality]
    os.makedirs(args.out, exist_ok=True)
    obj = os.path.join(args.out, "obj", "scene.obj")
    subprocess.run([args.bin, "--seed", str(args.seed), "--format", "obj", "--out", os.path.dirname(obj)],
                   check=True, stdout=subprocess.DEVNULL)
    scene_json = os.path.join(os.path.dirname(obj), "scene.json")

    one = run_scene_gen(args.bin, args, 1, os.path.join(args.out, "dataset_1"))
    many_dir = os.path.join(args.out, "dataset_n")
    many = run_scene_gen(args.bin, args, args.frames, many_dir)
    views = frame_views(many_dir)
    if len(views) != args.frames:
        sys.exit(f"dataset_speed: the dataset holds {len(views)} frames, not {args.frames}")
    ours = (many - one) / (args.frames - 1)
    rows = [{"renderer": "scene-gen", "quality": args.quality, "spp": spp, "frame_s": round(ours, 3),
             "fps": round(1.0 / ours, 2), "run_fps": round(args.frames / many, 2), "run_s": round(many, 2),
             "one_frame_run_s": round(one, 2)}]
    print(json.dumps(rows[0]), flush=True)

    lights = json.load(open(scene_json))["lights"]
    t0 = time.perf_counter()
    shapes = house_shapes(obj, args.out)
    load_s = time.perf_counter() - t0
    for depth in depths:
        first, per_frame = time_mitsuba(shapes, lights, views, spp, depth)
        row = {"renderer": "mitsuba", "integrator": f"path max_depth {depth}", "spp": spp,
               "frame_s": round(per_frame, 3), "fps": round(1.0 / per_frame, 2), "first_frame_s": round(first, 2),
               "house_load_s": round(load_s, 2), "speed_up": round(per_frame / ours, 2)}
        rows.append(row)
        print(json.dumps(row), flush=True)
    w, h, _ = views[0]
    print(f"\n{w}x{h}, {args.frames} frames of house {args.seed}, {spp} spp, {os.cpu_count()} CPUs\n")
    print("| renderer | s per frame | frames per s | Mitsuba / scene-gen |")
    print("|---|---|---|---|")
    print(f"| scene-gen `--quality {args.quality}` | {ours:.3f} | {1 / ours:.2f} | |")
    for r in rows[1:]:
        print(f"| Mitsuba {r['integrator']} | {r['frame_s']:.3f} | {r['fps']:.2f} | {r['speed_up']:.2f} |")


if __name__ == "__main__":
    main()
