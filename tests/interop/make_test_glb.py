"""Writes a small hand-made GLB and its manifest by the scene-gen glTF contract, to test the
Blender scripts without the real glTF exporter (test-only; uses pygltflib).

    python tests/interop/make_test_glb.py OUT_DIR [--shift-mm N]

OUT_DIR/scene.glb holds a floor, a table (yawed 30 degrees, so its box is not its mesh's) with
a child leg mesh, a chair and a threshold, as Y-up nodes named `<class>_<id>` with extras
{class, class_id, instance_id, room, room_type}. OUT_DIR/scene.json is a manifest with one room,
one door, and the exact world (Z-up) bounds of each labelled node; --shift-mm moves the
manifest's table bounds, to prove the check notices.
"""

import json
import math
import os
import struct
import sys

import pygltflib as g


def box(size):
    """Positions, normals and indices of a centred box (Y-up frame)."""
    hx, hy, hz = (s / 2 for s in size)
    faces = [((1, 0, 0), (0, 1, 0), (0, 0, 1)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
             ((0, 1, 0), (0, 0, 1), (1, 0, 0)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
             ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (0, 1, 0), (1, 0, 0))]
    pos, nrm, idx = [], [], []
    for n, u, v in faces:
        base = len(pos)
        for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            p = [n[i] + u[i] * s + v[i] * t for i in range(3)]
            pos.append((p[0] * hx, p[1] * hy, p[2] * hz))
            nrm.append(n)
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nrm, idx


def to_y_up(p):
    x, y, z = p
    return (x, z, -y)


def quat_about_y_up_axis(yaw_deg):
    """Rotation about world +Z (glTF +Y), as a glTF quaternion (x, y, z, w)."""
    half = math.radians(yaw_deg) / 2
    return [0.0, math.sin(half), 0.0, math.cos(half)]


def main(argv):
    out = argv[1]
    shift_m = float(argv[argv.index("--shift-mm") + 1]) / 1000 if "--shift-mm" in argv else 0.0
    os.makedirs(out, exist_ok=True)
    blob = bytearray()
    gltf = g.GLTF2(scene=0, scenes=[g.Scene(nodes=[])], asset=g.Asset(version="2.0", generator="make_test_glb.py"))
    gltf.materials.append(g.Material(name="grey", pbrMetallicRoughness=g.PbrMetallicRoughness(
        baseColorFactor=[0.6, 0.6, 0.6, 1.0], metallicFactor=0.0, roughnessFactor=0.8)))

    def add_mesh(name, size):
        pos, nrm, idx = box(size)
        views = []
        for data, fmt, target in ((pos, "<3f", g.ARRAY_BUFFER), (nrm, "<3f", g.ARRAY_BUFFER),
                                  (idx, "<I", g.ELEMENT_ARRAY_BUFFER)):
            while len(blob) % 4:
                blob.append(0)
            start = len(blob)
            for item in data:
                blob.extend(struct.pack(fmt, *(item if isinstance(item, tuple) else (item,))))
            gltf.bufferViews.append(g.BufferView(buffer=0, byteOffset=start, byteLength=len(blob) - start, target=target))
            views.append(len(gltf.bufferViews) - 1)
        lo = [min(p[i] for p in pos) for i in range(3)]
        hi = [max(p[i] for p in pos) for i in range(3)]
        gltf.accessors += [
            g.Accessor(bufferView=views[0], componentType=g.FLOAT, count=len(pos), type=g.VEC3, min=lo, max=hi),
            g.Accessor(bufferView=views[1], componentType=g.FLOAT, count=len(nrm), type=g.VEC3),
            g.Accessor(bufferView=views[2], componentType=g.UNSIGNED_INT, count=len(idx), type=g.SCALAR),
        ]
        a = len(gltf.accessors) - 3
        gltf.meshes.append(g.Mesh(name=name, primitives=[g.Primitive(
            attributes=g.Attributes(POSITION=a, NORMAL=a + 1), indices=a + 2, material=0)]))
        return len(gltf.meshes) - 1

    def add_node(node, root=True):
        gltf.nodes.append(node)
        if root:
            gltf.scenes[0].nodes.append(len(gltf.nodes) - 1)
        return len(gltf.nodes) - 1

    room = {"id": 0, "type": "living_room", "min": [0.0, 0.0], "max": [5.0, 4.0]}
    add_node(g.Node(name="floor_0", mesh=add_mesh("floor", (5.0, 0.02, 4.0)), translation=list(to_y_up((2.5, 2.0, -0.01)))))

    def extras(cls, class_id, instance_id):
        return {"class": cls, "class_id": class_id, "instance_id": instance_id, "room": 0, "room_type": "living_room"}

    # Table: 1.4 x 0.8 x 0.75 (Z-up) centred at (2.0, 2.0, 0.375), yawed 30 degrees, with a child
    # leg node inside its box (the check must gather child meshes into the object's box).
    table_size_zup = (1.4, 0.8, 0.75)
    table = add_node(g.Node(name="table_0", mesh=add_mesh("table", to_y_up_size(table_size_zup)),
                            translation=list(to_y_up((2.0, 2.0, 0.375))), rotation=quat_about_y_up_axis(30.0),
                            extras=extras("table", 3, 2)))
    leg = add_node(g.Node(name="table_0_leg", mesh=add_mesh("leg", (0.05, 0.7, 0.05)),
                          translation=list(to_y_up((0.6, 0.3, -0.025)))), root=False)
    gltf.nodes[table].children = [leg]
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    hx, hy = table_size_zup[0] / 2, table_size_zup[1] / 2
    ex, ey = abs(c * hx) + abs(s * hy), abs(s * hx) + abs(c * hy)
    table_min = [2.0 - ex, 2.0 - ey, 0.0]
    table_max = [2.0 + ex, 2.0 + ey, 0.75]

    add_node(g.Node(name="chair_1", mesh=add_mesh("chair", to_y_up_size((0.45, 0.5, 0.9))),
                    translation=list(to_y_up((3.5, 1.0, 0.45))), extras=extras("chair", 4, 3)))
    add_node(g.Node(name="threshold_0", mesh=add_mesh("threshold", to_y_up_size((0.9, 0.1, 0.03))),
                    translation=list(to_y_up((2.5, 0.0, 0.015))), extras=extras("threshold", 11, 1)))

    gltf.buffers.append(g.Buffer(byteLength=len(blob)))
    gltf.set_binary_blob(bytes(blob))
    gltf.save_binary(os.path.join(out, "scene.glb"))

    def obj(i, cls, instance_id, lo, hi):
        return {"id": i, "class": cls, "instance_id": instance_id, "room": 0, "asset": f"{cls}/box",
                "min": lo, "max": hi, "yaw_deg": 0.0, "on": None}

    manifest = {
        "schema": "scene-gen/scene/1", "seed": 0, "generator_version": "test",
        "envelope": {"width_m": 5.0, "depth_m": 4.0, "height_m": 3.0}, "wall_thickness_m": 0.1,
        "rooms": [room], "walls": [], "windows": [], "lights": [],
        "doors": [{"id": 0, "rooms": [0, None], "wall": 0, "center": [2.5, 0.0, 1.0], "width_m": 0.9,
                   "height_m": 2.0, "normal": [0.0, -1.0]}],
        "thresholds": [{"id": 0, "door": 0, "instance_id": 1, "min": [2.05, -0.05, 0.0], "max": [2.95, 0.05, 0.03]}],
        "objects": [obj(0, "table", 2, table_min, [table_max[0] + shift_m, table_max[1], table_max[2]]),
                    obj(1, "chair", 3, [3.275, 0.75, 0.0], [3.725, 1.25, 0.9])],
    }
    with open(os.path.join(out, "scene.json"), "w", encoding="utf-8") as f:
        json.dump(manifest, f, indent=1)


def to_y_up_size(size):
    x, y, z = size
    return (x, z, y)


if __name__ == "__main__":
    main(sys.argv)
