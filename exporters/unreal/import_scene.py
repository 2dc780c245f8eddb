"""Unreal Editor Python: imports a scene-gen house into the open level and tags every labelled
actor with its class.

Run inside the Unreal Editor (Python Editor Script Plugin enabled), e.g. from the Output Log's
Python console:

    py "C:/path/to/scene-gen/exporters/unreal/import_scene.py" "C:/path/to/out/scene.glb"

or with `scene.usda` / `scene.usdc` (needs the USD Importer plugin). The manifest `scene.json`
beside the file gives each labelled item's class and ids.

After import every actor whose label is an object or threshold name (`<class>_<id>`, the glTF
node name / USD prim name of the exporters) gets the actor tags `<class>`, `class:<class>`,
`class_id:<n>` and `instance_id:<n>`, so Blueprints and the Movie Render Queue's stencil setup
can find them with `Get All Actors with Tag`. Tags are taken from the manifest rather than from
glTF extras or USD semantics, which Unreal's importers keep in places that differ between
engine versions.

Written against the Unreal 5.3+ Python API (Interchange glTF importer, `unreal.USDStageActor`);
it has not been run here (no Unreal Editor on this machine).
"""

import json
import os
import re
import sys

import unreal

LABEL = re.compile(r"^(sofa|bed|table|chair|bathtub|basin|computer|plant|lamp|toy|threshold)_(\d+)$")
CONTENT_FOLDER = "/Game/SceneGen"


def manifest_labels(scene_file):
    """`<class>_<id>` -> (class, class_id, instance_id) from the manifest beside the scene."""
    with open(os.path.join(os.path.dirname(scene_file), "scene.json"), encoding="utf-8") as f:
        manifest = json.load(f)
    classes = ["sofa", "bed", "table", "chair", "bathtub", "basin", "computer", "plant", "lamp", "toy"]
    labels = {f"{o['class']}_{o['id']}": (o["class"], classes.index(o["class"]) + 1, o["instance_id"])
              for o in manifest["objects"]}
    labels.update({f"threshold_{t['id']}": ("threshold", 11, t["instance_id"]) for t in manifest["thresholds"]})
    return labels


def import_gltf(path):
    """Imports the GLB into the current level (actors per node) with Interchange. glTF is Y up
    in metres; Interchange converts to Unreal's Z up centimetres (x100) itself."""
    source = unreal.InterchangeManager.create_source_data(path)
    params = unreal.ImportAssetParameters()
    params.is_automated = True
    unreal.InterchangeManager.get_interchange_manager_scripted().import_scene(CONTENT_FOLDER, source, params)


def import_usd(path):
    """Opens the USD stage in a USD Stage actor (live, not copied into assets); the importer
    reads metersPerUnit = 1 and upAxis = Z from the layer and converts to centimetres."""
    actor = unreal.EditorLevelLibrary.spawn_actor_from_class(unreal.UsdStageActor, unreal.Vector(0, 0, 0))
    actor.set_editor_property("root_layer", unreal.FilePath(path))
    actor.set_actor_label("scene_gen_stage")


def tag_actors(labels):
    tagged = 0
    subsystem = unreal.get_editor_subsystem(unreal.EditorActorSubsystem)
    for actor in subsystem.get_all_level_actors():
        match = LABEL.match(actor.get_actor_label())
        if not match or actor.get_actor_label() not in labels:
            continue
        cls, class_id, instance_id = labels[actor.get_actor_label()]
        tags = list(actor.tags)
        for tag in (cls, f"class:{cls}", f"class_id:{class_id}", f"instance_id:{instance_id}"):
            if tag not in [str(t) for t in tags]:
                tags.append(unreal.Name(tag))
        actor.tags = tags
        tagged += 1
    return tagged


def main(argv):
    if len(argv) < 2:
        raise SystemExit("usage: import_scene.py SCENE.glb|SCENE.usda|SCENE.usdc")
    path = os.path.abspath(argv[1])
    if path.endswith((".usda", ".usdc", ".usd")):
        import_usd(path)
    else:
        import_gltf(path)
    labels = manifest_labels(path)
    tagged = tag_actors(labels)
    unreal.log(f"scene-gen: imported {path}; tagged {tagged} of {len(labels)} labelled actors")
    if tagged < len(labels):
        unreal.log_warning("scene-gen: some labelled items have no actor of that name (USD stage actors "
                           "spawn prims as components, not actors: use the prim's semantics there)")


if __name__ == "__main__":
    main(sys.argv)
