"""scene-gen's global illumination against Mitsuba 3's path tracer on the same house, lights,
materials and views.

Run through examples/mitsuba/run_gi_compare.sh (it builds examples/gi_views, exports the house
as OBJ and sets DRJIT_LIBLLVM_PATH). gi_views writes one view per room with scene-gen's
radiance by day and by night, direct light only and with the irradiance volume. This script
builds the same house in Mitsuba:

* geometry and UVs from scene-gen's OBJ export (glass left out, as scene-gen's BVH leaves it
  out), one mesh per material with its vertex normals;
* a two-sided `diffuse` BSDF (scene-gen shades both sides of every face) whose reflectance is
  scene-gen's diffuse albedo: the texture (sRGB-decoded)
  times `Kd`, times `1 - Pm (1 - Pr)` (scene-gen shades that share of a metal as a mirror and
  the rest diffusely; Mitsuba gets the diffuse part only, a handful of small gold strips);
* the lights of scene.json with scene-gen's units and tints (a tint is scaled to unit
  luminance): points as `point` (candela as intensity), the sun as `directional` (lux as
  irradiance), windows as one-sided `rectangle` area emitters (nit as radiance) with a black
  BSDF.

scene-gen's window emitters do not block light (they stand in an opening, and the sun shines
through it), while Mitsuba's rectangles would, so the day image is Mitsuba's render of the
windows alone plus its render of the sun alone (light adds linearly).

The reference is the `path` integrator with `--depth` (default 16: 15 bounces), rendered as two
halves of `--spp` samples with different seeds: their mean is the reference and their
difference measures its own noise. Reported per room and lighting: the mean luminance of
Mitsuba, of scene-gen with direct light only and of scene-gen with the volume, the relative
error of each mean, and per-pixel statistics on 4x4-pixel blocks (median and 90th percentile
of |ours - ref| / ref over blocks whose reference is above 5 % of the image mean, with the
same statistic between Mitsuba's two halves as the noise floor). Gate: every image mean and
every room's mean within `--tolerance` (default 5 %) with the volume; exit status 1 otherwise.

Mitsuba's renders are kept in `--out` (`mitsuba_room_<r>_<lighting>.npz`, with a digest of the
house, the view, spp, depth and Mitsuba's version); `--reuse` reads them back where the digest
matches, so other volume settings or render seeds (`gi_views --render-seed`) are compared in
seconds.
"""

import argparse
import hashlib
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant("llvm_ad_rgb")

from compare import load_obj_by_material, read_materials, write_ply_textured  # noqa: E402

LUMA = np.array([0.2126, 0.7152, 0.0722])


def diffuse_reflectance(material, out, k):
    """The Mitsuba texture of scene-gen's diffuse albedo for one material."""
    kd = np.clip(np.asarray(material["Kd"]), 0.0, 1.0)
    metallic = min(max(material["Pm"], 0.0), 1.0)
    roughness = min(max(material["Pr"], 0.0), 1.0)
    scale = kd * (1.0 - metallic * (1.0 - roughness))
    if material["map"] is None:
        return {"type": "rgb", "value": scale.tolist()}
    if np.allclose(scale, 1.0):
        return {"type": "bitmap", "filename": material["map"], "filter_type": "bilinear", "wrap_mode": "repeat"}
    # Premultiply: decode the sRGB texture to linear, scale, store as linear EXR.
    bitmap = mi.Bitmap(material["map"]).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    linear = np.clip(np.asarray(bitmap) * scale[None, None, :], 0.0, 1.0).astype(np.float32)
    path = os.path.join(out, f"albedo_{k:03}.exr")
    mi.Bitmap(linear).write(path)
    return {"type": "bitmap", "filename": path, "filter_type": "bilinear", "wrap_mode": "repeat", "raw": True}


def house_shapes(obj, out):
    materials = read_materials(obj)
    shapes = {}
    for k, (name, pos, uv, normals, faces, _texture) in enumerate(load_obj_by_material(obj)):
        ply = os.path.join(out, f"gi_material_{k:03}.ply")
        write_ply_textured(ply, pos, uv, normals, faces)
        shapes[f"house_{k:03}"] = {
            "type": "ply",
            "filename": ply,
            "face_normals": False,
            # Two-sided, as scene-gen shades every face from either side.
            "bsdf": {"type": "twosided",
                     "bsdf": {"type": "diffuse", "reflectance": diffuse_reflectance(materials[name], out, k)}},
        }
    return shapes


def unit_tint(color):
    c = np.maximum(np.asarray(color, dtype=np.float64), 0.0)
    y = float(c @ LUMA)
    return c / y if y > 0 else c * 0.0


def light_entries(lights, group, kinds):
    """Mitsuba emitters for the lights of `group` whose kind is in `kinds`."""
    entries = {}
    for light in lights:
        if light["group"] != group or light["kind"] not in kinds:
            continue
        rgb = (light["intensity"] * unit_tint(light["color"])).tolist()
        key = f"light_{light['id']}"
        if light["kind"] == "point":
            entries[key] = {"type": "point", "position": light["position"], "intensity": {"type": "rgb", "value": rgb}}
        elif light["kind"] == "directional":
            entries[key] = {"type": "directional", "direction": light["direction"],
                            "irradiance": {"type": "rgb", "value": rgb}}
        elif light["kind"] == "rect":
            u, v = np.asarray(light["rect_u"]), np.asarray(light["rect_v"])
            n = np.asarray(light["direction"], dtype=np.float64)
            n /= np.linalg.norm(n)
            c = np.asarray(light["position"])
            m = np.eye(4)
            m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u * 0.5, v * 0.5, n, c
            entries[key] = {
                "type": "rectangle",
                "to_world": mi.ScalarTransform4f(m.tolist()),
                "emitter": {"type": "area", "radiance": {"type": "rgb", "value": rgb}},
                "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.0}},
            }
    return entries


def sensor(cam, spp):
    pos = np.asarray(cam["position"], dtype=np.float64)
    target = pos + np.asarray(cam["forward"], dtype=np.float64)
    return {
        "type": "perspective",
        "fov": cam["hfov_deg"],
        "fov_axis": "x",
        "near_clip": 1e-3,
        "far_clip": 1e4,
        "to_world": mi.ScalarTransform4f().look_at(origin=pos.tolist(), target=target.tolist(),
                                                   up=[float(v) for v in cam["up"]]),
        "film": {"type": "hdrfilm", "width": cam["width"], "height": cam["height"],
                 "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": spp},
    }


def render_halves(shapes, emitters, cam, spp, depth):
    """Two renders of spp / 2 samples with different seeds, as (H, W, 3) arrays."""
    if not emitters:
        z = np.zeros((cam["height"], cam["width"], 3))
        return z, z
    scene = mi.load_dict({"type": "scene", "integrator": {"type": "path", "max_depth": depth, "rr_depth": depth},
                          "sensor": sensor(cam, spp // 2), **shapes, **emitters})
    halves = []
    for seed in (1, 2):
        img = mi.render(scene, spp=spp // 2, seed=seed)
        dr.eval(img)
        halves.append(np.asarray(img, dtype=np.float64))
    return halves[0], halves[1]


def reference_key(obj_path, cam, spp, depth):
    """What a Mitsuba render depends on: the house's OBJ, MTL and lights, the view, spp and depth."""
    digest = hashlib.sha256()
    base = os.path.dirname(obj_path)
    for path in (obj_path, os.path.join(base, "scene.mtl"), os.path.join(base, "scene.json")):
        with open(path, "rb") as f:
            digest.update(f.read())
    digest.update(json.dumps(cam, sort_keys=True).encode())
    digest.update(f"{spp}/{depth}/{mi.__version__}".encode())
    return digest.hexdigest()


def blocks(lum, b=4):
    h, w = lum.shape[0] // b * b, lum.shape[1] // b * b
    return lum[:h, :w].reshape(h // b, b, w // b, b).mean(axis=(1, 3))


def pixel_stats(ours, ref):
    """(median, 90th percentile) of the relative error of 4x4 blocks brighter than 5 % of the mean."""
    r, o = blocks(ref), blocks(ours)
    mask = r > 0.05 * ref.mean()
    if not mask.any():
        return 0.0, 0.0
    e = np.abs(o[mask] - r[mask]) / r[mask]
    return float(np.median(e)), float(np.percentile(e, 90))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--views", required=True, help="the folder gi_views --out wrote")
    ap.add_argument("--obj", required=True, help="scene.obj of the same house (scene.json beside it)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--depth", type=int, default=16)
    ap.add_argument("--tolerance", type=float, default=0.05)
    ap.add_argument("--reuse", action="store_true",
                    help="reuse Mitsuba renders an earlier run left in --out for the same house, view, spp and depth")
    args = ap.parse_args()
    # Bad input: a message and exit status 2 before anything is written.
    scene_json = os.path.join(os.path.dirname(args.obj), "scene.json")
    for path in (args.obj, scene_json, os.path.join(os.path.dirname(args.obj), "scene.mtl")):
        if not os.path.isfile(path):
            ap.error(f"{path}: no such file (export the house with `scene-gen --format obj`)")
    if not os.path.isdir(args.views) or not any(f.startswith("room_") and f.endswith(".json")
                                                for f in os.listdir(args.views)):
        ap.error(f"--views {args.views}: no room_<r>.json (write it with `gi_views --out`)")
    if args.spp < 2 or args.depth < 1:
        ap.error("--spp must be at least 2 (two halves) and --depth at least 1")
    os.makedirs(args.out, exist_ok=True)
    lights = json.load(open(scene_json))["lights"]
    shapes = house_shapes(args.obj, args.out)
    print(f"mitsuba {mi.__version__}, variant {mi.variant()}, path max_depth {args.depth}, {args.spp} spp", flush=True)
    rooms = sorted(int(f[5:-5]) for f in os.listdir(args.views) if f.startswith("room_") and f.endswith(".json"))
    rows, failures = [], []
    for room in rooms:
        cam = json.load(open(os.path.join(args.views, f"room_{room}.json")))
        h, w = cam["height"], cam["width"]
        scenes = {
            "night": [light_entries(lights, "night", {"point", "rect", "directional"})],
            "day": [light_entries(lights, "day", {"rect", "point"}), light_entries(lights, "day", {"directional"})],
        }
        for lighting, parts in scenes.items():
            t0 = time.perf_counter()
            cached = os.path.join(args.out, f"mitsuba_room_{room}_{lighting}.npz")
            key = reference_key(args.obj, cam, args.spp, args.depth)
            stored = np.load(cached) if args.reuse and os.path.isfile(cached) else None
            if stored is not None and str(stored["key"]) == key:
                a, b, seconds = stored["a"], stored["b"], float(stored["seconds"])
            else:
                a, b = np.zeros((h, w, 3)), np.zeros((h, w, 3))
                for emitters in parts:
                    pa, pb = render_halves(shapes, emitters, cam, args.spp, args.depth)
                    a, b = a + pa, b + pb
                seconds = time.perf_counter() - t0
                np.savez(cached, a=a, b=b, key=key, seconds=seconds)
            ref = 0.5 * (a + b) @ LUMA
            row = {"room": room, "lighting": lighting, "mitsuba_nit": float(ref.mean()), "mitsuba_s": round(seconds, 1),
                   "noise_floor": pixel_stats(a @ LUMA, b @ LUMA)}
            for kind in ("direct", "volume"):
                raw = np.fromfile(os.path.join(args.views, f"room_{room}_{lighting}_{kind}.f32"), dtype="<f4")
                ours = raw.reshape(h, w, 3).astype(np.float64) @ LUMA
                row[f"{kind}_nit"] = float(ours.mean())
                row[f"{kind}_error"] = float(ours.mean() / max(ref.mean(), 1e-12) - 1.0)
                row[f"{kind}_blocks"] = pixel_stats(ours, ref)
            rows.append(row)
            if abs(row["volume_error"]) > args.tolerance:
                failures.append(f"room {room} {lighting}: image mean off by {100 * row['volume_error']:+.1f} %")
            print(json.dumps(row), flush=True)
    print()
    print("| room | lighting | Mitsuba nit | direct only | with volume | blocks: median, p90 (volume) | Mitsuba's own |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        vb, nf = r["volume_blocks"], r["noise_floor"]
        print(f"| {r['room']} | {r['lighting']} | {r['mitsuba_nit']:.4f} | {100 * r['direct_error']:+.1f} % | "
              f"**{100 * r['volume_error']:+.1f} %** | {100 * vb[0]:.1f} %, {100 * vb[1]:.1f} % | "
              f"{100 * nf[0]:.1f} %, {100 * nf[1]:.1f} % |")
    json.dump(rows, open(os.path.join(args.out, "gi_results.json"), "w"), indent=1)
    if failures:
        print("FAIL: " + "; ".join(failures))
        sys.exit(1)
    print(f"all image means within {100 * args.tolerance:.0f} % of Mitsuba")


if __name__ == "__main__":
    main()
