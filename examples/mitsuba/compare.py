"""scene-gen's ray tracer against Mitsuba 3 (llvm_ad_rgb) on the same house, view and workload.

Run through examples/mitsuba/run_compare.sh (it builds the benchmark, exports the OBJ and sets
DRJIT_LIBLLVM_PATH). For each resolution it asks target/release/examples/bench_render for the
camera of its benchmark pose (JSON) and the ray distance of every pixel-centre ray, loads the
house from scene-gen's OBJ export (glass left out, as scene-gen's BVH leaves it out), and then,
per thread count, times interleaved in one run:

* primary: closest hit of one ray through every pixel centre. scene-gen: `Accel::closest_hit`;
  Mitsuba: `Scene.ray_intersect_preliminary` on the very same rays (distance + barycentrics).
* shadow: one occlusion ray from every primary hit to the night ceiling light. scene-gen:
  `Accel::occluded`; Mitsuba: `Scene.ray_test` on the same rays.
* depth: Mitsuba's `depth` integrator at 1 spp (camera sampling, film) for the primary pass as
  a renderer runs it; compared with scene-gen's primary batch.
* direct: a rendered image of the house lit by that point light, `--spp` samples per pixel.
  scene-gen: `Renderer::render` (label ray + spp camera rays, a shadow ray per hit, textured
  Lambertian); Mitsuba: `direct` integrator, emitter_samples=1, bsdf_samples=0, one grey
  diffuse BSDF, face normals. Mitsuba does less work here than scene-gen: no textures, no
  interpolated normals, no label pass.
* image: the same image, with Mitsuba doing scene-gen's work: the house as one mesh per
  material with its UVs, vertex normals and texture (bilinear, repeating: how scene-gen samples
  it) under a diffuse BSDF, `direct` at `--spp`; plus the label pass, Mitsuba's `aov`
  integrator at one pixel-centre sample (depth, shading normal, shape index), as scene-gen's
  label ray gives depth, normal and ids. Mitsuba's time is the sum of the two renders. The mean
  green radiance of the two images must agree within 5 % (same lights, textures and BRDF).

Dr.Jit compiles a kernel the first time a computation runs: every Mitsuba case is run once
untimed (its time is reported as `first_s`, JIT compile or kernel-cache load included), then
timed `--repeats` times. The figure compared is the best time of each.

Before timing it checks both renderers see the same view: the hit masks of scene-gen's
pixel-centre rays and of Mitsuba's `depth` image (stratified, unjittered, 1 spp: also pixel
centres) must agree on more than 99 % of the pixels, and so must the distances within 1 cm.
"""

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

import drjit as dr
import mitsuba as mi

mi.set_variant("llvm_ad_rgb")


def read_materials(obj_path):
    """{material name: {"Kd", "Pm", "Pr", "d", "map"}} of the scene.mtl beside an OBJ export
    (scene-gen writes Kd, d, the PBR keys Pr and Pm, and map_Kd; a missing key is the default)."""
    folder = os.path.dirname(obj_path)
    materials, name = {}, None
    with open(os.path.join(folder, "scene.mtl")) as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "newmtl":
                name = parts[1]
                materials[name] = {"Kd": [1.0, 1.0, 1.0], "Pm": 0.0, "Pr": 1.0, "d": 1.0, "map": None}
            elif parts[0] == "Kd":
                materials[name]["Kd"] = [float(v) for v in parts[1:4]]
            elif parts[0] in ("Pm", "Pr", "d"):
                materials[name][parts[0]] = float(parts[1])
            elif parts[0] == "map_Kd":
                materials[name]["map"] = os.path.join(folder, parts[1])
    return materials


def read_mtl(obj_path):
    """(glass material names, {material: texture path}) of the scene.mtl beside an OBJ export.

    A material is glass when scene-gen's `is_transparent` says so: its name starts with `glass`
    or its alpha `d` < 0.5.
    """
    materials = read_materials(obj_path)
    # Names are m<index:03>_<material name>.
    glass = {n for n, m in materials.items() if n.split("_", 1)[-1].startswith("glass") or m["d"] < 0.5}
    textures = {n: m["map"] for n, m in materials.items() if m["map"] is not None}
    return glass, textures


def load_obj_z_up(path):
    """Vertices (Z up, metres) and the triangles of scene-gen's OBJ export, glass left out: the
    meshes of `load_obj_by_material` in one."""
    vertices, faces, offset = [], [], 0
    for _, positions, _, _, triangles, _ in load_obj_by_material(path):
        vertices.append(positions)
        faces.append(triangles + offset)
        offset += len(positions)
    return np.concatenate(vertices), np.concatenate(faces).astype(np.int32)


def load_obj_by_material(path):
    """Per opaque material of scene-gen's OBJ export: (name, positions Z up, uvs, normals,
    triangles, texture path or None), each corner's (v, vt, vn) made one vertex.

    The export writes world (x, y, z) as (x, z, -y); this undoes it.
    """
    glass, textures = read_mtl(path)
    v, vt, vn, faces, material = [], [], [], {}, None
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                _, x, y, z = line.split()
                v.append((float(x), -float(z), float(y)))
            elif line.startswith("vt "):
                vt.append(tuple(float(c) for c in line.split()[1:3]))
            elif line.startswith("vn "):
                _, x, y, z = line.split()
                vn.append((float(x), -float(z), float(y)))
            elif line.startswith("usemtl "):
                material = line.split()[1]
            elif line.startswith("f ") and material not in glass:
                idx = [tuple(int(i) - 1 for i in p.split("/")) for p in line.split()[1:]]
                for k in range(1, len(idx) - 1):
                    faces.setdefault(material, []).append((idx[0], idx[k], idx[k + 1]))
    v, vt, vn = (np.asarray(a, dtype=np.float32) for a in (v, vt, vn))
    meshes = []
    for material, tris in faces.items():
        corners = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
        keys, inverse = np.unique(corners, axis=0, return_inverse=True)
        meshes.append((material, v[keys[:, 0]], vt[keys[:, 1]], vn[keys[:, 2]],
                       inverse.reshape(-1, 3).astype(np.int32), textures.get(material)))
    return meshes


def write_ply_textured(path, positions, uvs, normals, faces):
    """Binary PLY with per-vertex normals and UVs (`nx ny nz u v`, as Mitsuba's `ply` reads)."""
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(positions)}\nproperty float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    vertex = np.concatenate([positions, normals, uvs], axis=1).astype("<f4")
    face_rec = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    face_rec["n"] = 3
    face_rec["i"] = faces
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(vertex.tobytes())
        f.write(face_rec.tobytes())


def textured_shapes(obj, out):
    """Mitsuba shape entries for the house as scene-gen shades it: one mesh per material."""
    shapes = {}
    for k, (name, pos, uv, normals, faces, texture) in enumerate(load_obj_by_material(obj)):
        ply = os.path.join(out, f"material_{k:03}.ply")
        write_ply_textured(ply, pos, uv, normals, faces)
        reflectance = ({"type": "bitmap", "filename": texture, "filter_type": "bilinear", "wrap_mode": "repeat"}
                       if texture else {"type": "rgb", "value": 0.5})
        shapes[f"house_{k:03}"] = {"type": "ply", "filename": ply, "face_normals": False,
                                   "bsdf": {"type": "diffuse", "reflectance": reflectance}}
    return shapes


def write_ply(path, vertices, faces):
    """Binary little-endian PLY of a triangle mesh (what Mitsuba's `ply` plugin reads)."""
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(vertices)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    face_rec = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    face_rec["n"] = 3
    face_rec["i"] = faces
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(vertices.astype("<f4").tobytes())
        f.write(face_rec.tobytes())


def bench(binary, case, w, h, threads, extra=()):
    """One scene-gen case: the JSON line bench_render prints."""
    cmd = [binary, "--case", case, "--res", f"{w}x{h}", "--threads", str(threads), *extra]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def pixel_centre_directions(cam):
    """The unit directions scene-gen's `Camera::ray_direction` gives pixel centres (f32)."""
    w, h = cam["width"], cam["height"]
    pitch_mm = np.float32(cam["pixel_pitch_um"] * 1e-3)
    xs = (np.arange(w, dtype=np.float32) + np.float32(0.5) - np.float32(w * 0.5)) * pitch_mm
    ys = (np.float32(h * 0.5) - (np.arange(h, dtype=np.float32) + np.float32(0.5))) * pitch_mm
    f, r, u = (np.asarray(cam[k], dtype=np.float32) for k in ("forward", "right", "up"))
    d = f[None, None, :] * np.float32(cam["focal_mm"]) + xs[None, :, None] * r + ys[:, None, None] * u
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    return d.reshape(-1, 3).astype(np.float32)


def vec(a):
    return mi.Vector3f(mi.Float(a[:, 0]), mi.Float(a[:, 1]), mi.Float(a[:, 2]))


def pt(a):
    return mi.Point3f(mi.Float(a[:, 0]), mi.Float(a[:, 1]), mi.Float(a[:, 2]))


def timed(run, repeats):
    """(first call s, [timed calls s], mean CPU s per timed call); `run` must evaluate and wait
    for its result. CPU time (all threads) is what the work costs whatever else the machine
    runs; the wall time also measures the scheduler."""
    t0 = time.perf_counter()
    run()
    first = time.perf_counter() - t0
    times = []
    cpu0 = time.process_time()
    for _ in range(repeats):
        t0 = time.perf_counter()
        run()
        times.append(time.perf_counter() - t0)
    return first, times, (time.process_time() - cpu0) / repeats


def mitsuba_scene(ply, cam, spp, sampler="independent", integrator=None, light=True, shapes=None):
    pos = np.asarray(cam["position"], dtype=np.float64)
    target = pos + np.asarray(cam["forward"], dtype=np.float64)
    to_world = mi.ScalarTransform4f().look_at(
        origin=pos.tolist(), target=target.tolist(), up=[float(v) for v in cam["up"]]
    )
    sampler_dict = {"type": sampler, "sample_count": spp}
    if sampler == "stratified":
        sampler_dict["jitter"] = False
    scene = {
        "type": "scene",
        "integrator": integrator or {"type": "depth"},
        "sensor": {
            "type": "perspective",
            "fov": cam["hfov_deg"],
            "fov_axis": "x",
            "near_clip": 1e-4,
            "far_clip": 1e4,
            "to_world": to_world,
            "film": {
                "type": "hdrfilm",
                "width": cam["width"],
                "height": cam["height"],
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },
            "sampler": sampler_dict,
        },
    }
    if shapes:
        scene.update(shapes)
    else:
        scene["house"] = {
            "type": "ply",
            "filename": ply,
            "face_normals": True,
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}},
        }
    if light:
        i = cam["light_intensity_cd"]
        scene["light"] = {
            "type": "point",
            "position": cam["light_position"],
            "intensity": {"type": "rgb", "value": [i, i, i]},
        }
    return mi.load_dict(scene)


def render_eval(scene, spp):
    img = mi.render(scene, spp=spp, seed=0)
    dr.eval(img)
    dr.sync_thread()
    return img


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bench", required=True, help="target/release/examples/bench_render")
    ap.add_argument("--obj", required=True, help="scene.obj of `scene-gen --seed 7 --format obj`")
    ap.add_argument("--out", required=True, help="folder for the PLY, depth images and results.json")
    ap.add_argument("--res", nargs="+", default=["640x480", "1936x1216"])
    ap.add_argument("--threads", nargs="+", type=int, default=[1, 2])
    ap.add_argument("--spp", type=int, default=4, help="samples per pixel of the direct case (a square)")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)

    vertices, faces = load_obj_z_up(args.obj)
    ply = os.path.join(args.out, "house_z_up.ply")
    write_ply(ply, vertices, faces)
    shapes = textured_shapes(args.obj, args.out)
    textured_count = len(shapes)
    print(f"mitsuba {mi.__version__}, drjit {dr.__version__}, variant {mi.variant()}; "
          f"house: {len(faces)} triangles (glass left out)", flush=True)

    results = []
    failures = []
    for res in args.res:
        w, h = (int(v) for v in res.split("x"))
        cam_path = os.path.join(args.out, f"camera_{res}.json")
        depth_path = os.path.join(args.out, f"depth_scene_gen_{res}.f32")
        bench(args.bench, "primary", w, h, 1, ["--camera-out", cam_path, "--depth-out", depth_path])
        cam = json.load(open(cam_path))
        if cam["triangles"] != len(faces):
            failures.append(f"{res}: scene-gen BVH has {cam['triangles']} triangles, the OBJ {len(faces)}")
        t_ours = np.fromfile(depth_path, dtype="<f4")

        # Same view? Mitsuba's own camera, pixel centres, against scene-gen's depth.
        check = mitsuba_scene(ply, cam, 1, sampler="stratified", light=False)
        d_mi = np.asarray(render_eval(check, 1))[:, :, 0].reshape(-1)
        hit_ours, hit_mi = np.isfinite(t_ours), d_mi > 0
        agree = float(np.mean(hit_ours == hit_mi))
        both = hit_ours & hit_mi
        close = float(np.mean(np.abs(t_ours[both] - d_mi[both]) < 0.01)) if both.any() else 0.0
        np.save(os.path.join(args.out, f"depth_mitsuba_{res}.npy"), d_mi.reshape(h, w))
        print(f"{res}: hit masks agree on {agree:.2%} of pixels, distances within 1 cm on {close:.2%} "
              f"of common hits (scene-gen hits {hit_ours.mean():.2%}, Mitsuba {hit_mi.mean():.2%})", flush=True)
        if agree < 0.99 or close < 0.99:
            failures.append(f"{res}: views differ (mask agreement {agree:.4f}, distance agreement {close:.4f})")

        # The same rays for both.
        origin = np.asarray(cam["position"], dtype=np.float32)
        dirs = pixel_centre_directions(cam)
        n = len(dirs)
        prim_rays = mi.Ray3f(pt(np.broadcast_to(origin, (n, 3)).copy()), vec(dirs))
        pts = origin + dirs[np.isfinite(t_ours)] * t_ours[np.isfinite(t_ours), None]
        to = np.asarray(cam["light_position"], dtype=np.float32) - pts
        dist = np.linalg.norm(to, axis=1)
        sdir = to / dist[:, None]
        shadow_rays = mi.Ray3f(pt(pts + sdir * 1e-3), vec(sdir))
        shadow_rays.maxt = mi.Float(dist - 2e-3)
        dr.eval(prim_rays, shadow_rays)
        scene = mitsuba_scene(ply, cam, 1)
        direct_integrator = {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0}
        direct = mitsuba_scene(ply, cam, args.spp, integrator=direct_integrator)
        textured = mitsuba_scene(ply, cam, args.spp, integrator=direct_integrator, shapes=shapes)
        labels = mitsuba_scene(ply, cam, 1, sampler="stratified", light=False, shapes=shapes,
                               integrator={"type": "aov", "aovs": "dd:depth,nn:sh_normal,si:shape_index"})

        for threads in args.threads:
            dr.set_thread_count(threads)
            ours = {c: bench(args.bench, c, w, h, threads) for c in ("primary", "shadow")}
            ours["direct"] = bench(args.bench, "direct", w, h, threads, ["--spp", str(args.spp)])

            def primary():
                pi = scene.ray_intersect_preliminary(prim_rays)
                dr.eval(pi.t, pi.prim_uv)
                dr.sync_thread()
                return pi

            def shadow():
                blocked = scene.ray_test(shadow_rays)
                dr.eval(blocked)
                dr.sync_thread()
                return blocked

            def image():
                return render_eval(labels, 1), render_eval(textured, args.spp)

            mit = {
                "primary": timed(primary, args.repeats),
                "shadow": timed(shadow, args.repeats),
                "depth": timed(lambda: render_eval(scene, 1), args.repeats),
                "direct": timed(lambda: render_eval(direct, args.spp), args.repeats),
                "image": timed(image, args.repeats),
            }
            # Same picture? Mean green radiance of the textured image against scene-gen's.
            mean_mi = float(np.asarray(render_eval(textured, args.spp))[:, :, 1].mean())
            mean_ours = ours["direct"]["mean_green_nit"]
            if abs(mean_mi / mean_ours - 1.0) > 0.05:
                failures.append(f"{res}: textured images differ (mean green {mean_ours:.5f} vs Mitsuba {mean_mi:.5f})")
            blocked_mi = int(np.asarray(shadow()).sum())
            rays = {"primary": n, "shadow": len(pts), "depth": n}
            for case, (first, times, cpu_s) in mit.items():
                mine = ours[{"depth": "primary", "image": "direct"}.get(case, case)]
                row = {
                    "res": res, "threads": threads, "case": case,
                    "scene_gen_s": mine["best_s"], "scene_gen_times_s": mine["times_s"],
                    "mitsuba_s": min(times), "mitsuba_times_s": times, "mitsuba_first_s": first,
                    "scene_gen_cpu_s": mine["cpu_s"], "mitsuba_cpu_s": cpu_s,
                    "ratio": mine["best_s"] / min(times),
                    "cpu_ratio": mine["cpu_s"] / cpu_s if cpu_s > 0 else None,
                }
                if case in rays:
                    row["rays"] = rays[case]
                    row["scene_gen_mrays_s"] = rays[case] / mine["best_s"] / 1e6
                    row["mitsuba_mrays_s"] = rays[case] / min(times) / 1e6
                if case == "shadow":
                    row["blocked"] = {"scene_gen": mine["blocked"], "mitsuba": blocked_mi}
                if case in ("direct", "image"):
                    row["spp"] = args.spp
                if case == "image":
                    row["mean_green_nit"] = {"scene_gen": mean_ours, "mitsuba": mean_mi}
                    row["mitsuba_meshes"] = textured_count
                results.append(row)
                print(json.dumps(row), flush=True)

    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({"results": results, "failures": failures}, f, indent=1)
    print("\n| resolution | threads | case | scene-gen | Mitsuba (first call) | ratio (wall) | ratio (CPU) |")
    print("|---|---|---|---|---|---|---|")
    for r in results:
        rate = lambda k: f" ({r[k]:.2f} Mrays/s)" if k in r else ""
        print(f"| {r['res']} | {r['threads']} | {r['case']} | {r['scene_gen_s'] * 1e3:.1f} ms"
              f"{rate('scene_gen_mrays_s')} | {r['mitsuba_s'] * 1e3:.1f} ms{rate('mitsuba_mrays_s')} "
              f"({r['mitsuba_first_s']:.2f} s) | {r['ratio']:.2f} | {r['cpu_ratio'] or float('nan'):.2f} |")
    for f in failures:
        print("FAILED:", f, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
