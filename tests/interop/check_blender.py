"""Imports a scene-gen GLB (or USD) into Blender (the `bpy` module) and checks it against the
manifest.

    python tests/interop/check_blender.py SCENE.glb|SCENE.usda|SCENE.usdc|SCENE.obj [SCENE.json]

The contract (docs/CONTRACTS.md, crates/export/src/gltf.rs): every object and threshold is a glTF node named
`<class>_<id>` whose extras are {class, class_id, instance_id, room, room_type}; glTF is Y up in
metres. Blender's importer turns Y up back into Z up and node extras into custom properties, so
in Blender each labelled object must:
  * exist once, named `<class>_<id>`, with custom properties class, class_id and instance_id equal
    to the manifest's;
  * span, with all its child meshes, a world box within 1 mm of the manifest's min/max (hence
    dimensions within 1 mm too).
And the number of labelled Blender objects equals the manifest's objects + thresholds.

An empty, truncated or non-glTF file fails before Blender is asked anything.

USD goes through Blender's own USD importer: labelled prims become objects named `<class>_<id>`
whose custom attributes (`scenegen:class_id`, `scenegen:instance_id`) become custom
properties; the same count, property and bounds checks apply (Blender does not import the
UsdSemantics token arrays, so the class is read from the name there).
OBJ goes through Blender's OBJ importer with its default options, which make one Blender object
per `o` line: every node of the file must arrive as its own object (as many mesh objects as `o`
lines), and each labelled one, named `<class>_<id>`, must have the manifest's bounds within 1 mm
(OBJ carries no custom properties).
Exits non-zero with every failure listed.
"""

import json
import os
import struct
import sys

TOLERANCE_M = 1e-3
CLASS_IDS = {c: i + 1 for i, c in enumerate(
    ["sofa", "bed", "table", "chair", "bathtub", "basin", "computer", "plant", "lamp", "toy", "threshold"])}


def check_glb_header(path):
    """A GLB is 'glTF', version 2, its stated length, and a JSON chunk first (glTF 2.0 spec,
    section 4.4). Returns a reason it is not, or None."""
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 20:
        return f"{path} is {len(data)} bytes: not a GLB (empty or truncated; is the glTF exporter still a stub?)"
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF" or version != 2:
        return f"{path}: not a glTF 2.0 binary (magic {magic!r}, version {version})"
    if length != len(data):
        return f"{path}: header says {length} bytes, file has {len(data)}"
    chunk_length, chunk_type = struct.unpack_from("<I4s", data, 12)
    if chunk_type != b"JSON":
        return f"{path}: first chunk is {chunk_type!r}, not JSON"
    try:
        json.loads(data[20 : 20 + chunk_length])
    except ValueError as e:
        return f"{path}: JSON chunk does not parse: {e}"
    return None


def world_box(obj):
    """World-space box of an object and all its descendants' mesh vertices (None if no mesh)."""
    lo = [float("inf")] * 3
    hi = [float("-inf")] * 3
    found = False
    for o in [obj, *obj.children_recursive]:
        if o.type != "MESH":
            continue
        m = o.matrix_world
        for v in o.data.vertices:
            w = m @ v.co
            found = True
            for i in range(3):
                lo[i] = min(lo[i], w[i])
                hi[i] = max(hi[i], w[i])
    return (lo, hi) if found else None


def main(argv):
    glb = argv[1]
    manifest_path = argv[2] if len(argv) > 2 else os.path.join(os.path.dirname(glb), "scene.json")
    is_usd = glb.endswith((".usda", ".usdc", ".usd"))
    is_obj = glb.endswith(".obj")
    reason = None if is_usd or is_obj else check_glb_header(glb)
    if reason:
        print(f"FAIL {reason}", file=sys.stderr)
        return 1
    with open(manifest_path, encoding="utf-8") as f:
        manifest = json.load(f)

    import bpy  # late: the header check needs no Blender

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if is_usd:
        result = bpy.ops.wm.usd_import(filepath=os.path.abspath(glb))
    elif is_obj:
        result = bpy.ops.wm.obj_import(filepath=os.path.abspath(glb))
    else:
        result = bpy.ops.import_scene.gltf(filepath=os.path.abspath(glb))
    if result != {"FINISHED"}:
        print(f"FAIL Blender's importer returned {result}", file=sys.stderr)
        return 1

    failures = []
    expected = {}
    for o in manifest["objects"]:
        expected[f"{o['class']}_{o['id']}"] = (o["class"], o["instance_id"], o["min"], o["max"])
    for t in manifest["thresholds"]:
        expected[f"threshold_{t['id']}"] = ("threshold", t["instance_id"], t["min"], t["max"])

    marker = "scenegen:instance_id" if is_usd else "class"
    if is_obj:
        with open(glb, encoding="utf-8") as f:
            o_lines = sum(1 for line in f if line.startswith("o "))
        meshes = sum(1 for o in bpy.data.objects if o.type == "MESH")
        if meshes != o_lines:
            failures.append(f"{meshes} Blender mesh objects from {o_lines} `o` lines: objects were merged or split")
        labelled = {o.name: o for o in bpy.data.objects if o.name in expected}
    else:
        labelled = {o.name: o for o in bpy.data.objects if marker in o.keys()}
    if is_obj and len(labelled) != len(expected):
        failures.append(f"{len(labelled)} Blender objects carry an object's or threshold's name, manifest has "
                        f"{len(expected)} objects + thresholds")
    elif len(labelled) != len(expected):
        failures.append(f"{len(labelled)} Blender objects carry a `{marker}` property, manifest has "
                        f"{len(expected)} objects + thresholds")
    worst_mm = 0.0
    for name, (cls, instance_id, lo, hi) in sorted(expected.items()):
        obj = labelled.get(name)
        if obj is None:
            failures.append(f"{name}: no Blender object of that name with a `{marker}` property")
            continue
        if is_obj:
            got = want = None  # OBJ has no custom properties; the name is the label
        elif is_usd:
            got = {"class": name.rsplit("_", 1)[0], "class_id": obj.get("scenegen:class_id"),
                   "instance_id": obj.get("scenegen:instance_id")}
        else:
            got = {k: obj.get(k) for k in ("class", "class_id", "instance_id")}
        if not is_obj:
            want = {"class": cls, "class_id": CLASS_IDS[cls], "instance_id": instance_id}
        if got != want:
            failures.append(f"{name}: custom properties {got}, want {want}")
        box = world_box(obj)
        if box is None:
            failures.append(f"{name}: no mesh under it")
            continue
        err = max(max(abs(box[0][i] - lo[i]), abs(box[1][i] - hi[i])) for i in range(3))
        worst_mm = max(worst_mm, err * 1e3)
        if err > TOLERANCE_M:
            dims = [box[1][i] - box[0][i] for i in range(3)]
            want_dims = [hi[i] - lo[i] for i in range(3)]
            failures.append(f"{name}: world box {box[0]}..{box[1]} (dimensions {dims}) vs manifest {lo}..{hi} "
                            f"(dimensions {want_dims}): {err * 1e3:.3f} mm off")
    meshes = sum(1 for o in bpy.data.objects if o.type == "MESH")
    print(f"  Blender {bpy.app.version_string} imported {os.path.basename(os.path.dirname(os.path.abspath(glb)))}/{os.path.basename(glb)}: {len(bpy.data.objects)} objects "
          f"({meshes} meshes), {len(labelled)} labelled; worst bound error {worst_mm:.3f} mm")
    for message in failures:
        print(f"FAIL {message}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
