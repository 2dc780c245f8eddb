"""Renders the agent's first view of a scene-gen house with Blender Cycles on the CPU.

    .venv-blender/bin/python exporters/blender/render_first_view.py out/scene.glb out/view.png

(`.venv-blender` is made by tests/interop/check_blender.sh, or by hand:
`python3.11 -m venv .venv-blender && .venv-blender/bin/pip install -r tests/interop/requirements-blender.txt`.
Inside Blender: `blender -b -P exporters/blender/render_first_view.py -- out/scene.glb out/view.png`.)

Imports the GLB (glTF node extras become custom properties: `class`, `class_id`, ...), places a
camera 0.8 m above the floor at the centre of the first room of the manifest (scene.json beside
the GLB, or --manifest FILE) looking level at that room's first door, and renders with Cycles on
the CPU at low samples (--samples, default 16; --size WxH, default 640x480) so it takes about a
minute. `--pose-out FILE` writes the view's pose for `scene-gen render --poses FILE`, so both
renderers can show the same view (scripts/first_views does that for several seeds).

Lights come from the GLB (KHR_lights_punctual, imported in physical units); `--lighting day`
(default) or `night` keeps only that group (the `group` custom property from the light's node
extras), `both` keeps all. The scenes are lit like real rooms (about 20 lux by day, 2 lux by
night), far below what Blender's view transform expects, so the film is exposed up by
`--exposure` stops (default 7 by day, 10 by night), as a camera's auto-exposure would. A GLB
without lights gets a dim grey world instead of rendering black.
"""

import argparse
import json
import math
import os
import sys

import bpy
from mathutils import Vector

EYE_HEIGHT_M = 0.8  # the agent's camera height (TaCOS robot camera mount)
FOCAL_MM = 18.0  # on Blender's 36 mm sensor: about 90 degrees horizontal field of view


def parse(argv):
    if "--" in argv:
        argv = argv[argv.index("--") + 1 :]
    else:
        argv = argv[1:]
    p = argparse.ArgumentParser(description="Render the first view of a scene-gen GLB with Cycles (CPU).")
    p.add_argument("glb")
    p.add_argument("png")
    p.add_argument("--manifest", help="scene.json (default: beside the GLB)")
    p.add_argument("--samples", type=int, default=16)
    p.add_argument("--size", default="640x480")
    p.add_argument("--lighting", choices=["day", "night", "both"], default="day")
    p.add_argument("--exposure", type=float, help="film exposure in stops (default 7 by day, 10 by night)")
    p.add_argument("--pose-out", help="also write the view's pose as a one-row CSV that `scene-gen render --poses` reads")
    return p.parse_args(argv)


def first_view(manifest):
    """Eye position and a level target: the first room's centre, facing its first door (or the
    room's longer axis when it has no door)."""
    if not manifest["rooms"]:
        raise SystemExit("render_first_view: the manifest has no rooms")
    room = manifest["rooms"][0]
    cx = (room["min"][0] + room["max"][0]) / 2
    cy = (room["min"][1] + room["max"][1]) / 2
    eye = Vector((cx, cy, EYE_HEIGHT_M))
    doors = [d for d in manifest["doors"] if room["id"] in d["rooms"]]
    if doors:
        target = Vector((doors[0]["center"][0], doors[0]["center"][1], EYE_HEIGHT_M))
    else:
        wide = room["max"][0] - room["min"][0] >= room["max"][1] - room["min"][1]
        target = eye + (Vector((1, 0, 0)) if wide else Vector((0, 1, 0)))
    if (target - eye).length < 1e-6:
        target = eye + Vector((1, 0, 0))
    return eye, target


def main(argv):
    args = parse(argv)
    manifest_path = args.manifest or os.path.join(os.path.dirname(os.path.abspath(args.glb)), "scene.json")
    with open(manifest_path, encoding="utf-8") as f:
        manifest = json.load(f)
    width, height = (int(v) for v in args.size.lower().split("x"))

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if bpy.ops.import_scene.gltf(filepath=os.path.abspath(args.glb)) != {"FINISHED"}:
        raise SystemExit(f"render_first_view: Blender could not import {args.glb}")
    scene = bpy.context.scene

    eye, target = first_view(manifest)
    camera = bpy.data.objects.new("first_view", bpy.data.cameras.new("first_view"))
    camera.data.lens = FOCAL_MM
    camera.data.clip_start = 0.05
    camera.location = eye
    camera.rotation_euler = (target - eye).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera

    lights = [o for o in scene.objects if o.type == "LIGHT"]
    for light in lights:
        group = light.get("group")
        light.hide_render = args.lighting != "both" and group is not None and group != args.lighting
    lit = [o for o in lights if not o.hide_render]
    world = bpy.data.worlds.new("background")
    world.use_nodes = True
    grey = 0.0 if lit else 0.05
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (grey, grey, grey, 1.0)
    scene.world = world
    exposure = args.exposure if args.exposure is not None else (10.0 if args.lighting == "night" else 7.0)
    scene.view_settings.exposure = exposure if lit else 0.0

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = args.samples
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = os.path.abspath(args.png)
    bpy.ops.render.render(write_still=True)
    heading = math.degrees(math.atan2(target.y - eye.y, target.x - eye.x))
    if args.pose_out:
        with open(args.pose_out, "w", encoding="utf-8") as f:
            f.write("x,y,z,yaw_deg,pitch_deg\n")
            f.write(f"{eye.x:.4f},{eye.y:.4f},{eye.z:.4f},{heading:.3f},0\n")
    print(f"render_first_view: {args.png} ({width}x{height}, {args.samples} spp, {len(lit)} {args.lighting} lights, "
          f"exposure {scene.view_settings.exposure:+.1f}), eye {tuple(round(v, 3) for v in eye)}, "
          f"heading {heading:.1f} deg from +X")


if __name__ == "__main__":
    main(sys.argv)
