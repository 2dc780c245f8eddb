"""Checks scene-gen's USD export with usd-core (pxr) against the scene's manifest.

    python tests/interop/check_usd.py SCENE.usda SCENE.usdc   (both beside one scene.json)

For one scene written twice (text and binary layers) it checks:
  * stage metadata: metersPerUnit 1, upAxis Z, default prim /World;
  * every manifest object and threshold has exactly one prim labelled with its class in both
    semantics forms (UsdSemantics.LabelsAPI taxonomy `class`, Isaac Sim's legacy
    SemanticsAPI:Semantics) and its class and instance ids, and no other prim is labelled;
  * each labelled prim's world bounding box (tight, from the mesh points) is within 1 mm
    of the manifest's min/max;
  * the `lighting` variant set: `day` activates exactly the manifest's day lights, `night` the
    night lights, with the UsdLux types and unit conversions of crates/export/src/usd.rs;
  * every texture a UsdUVTexture reads exists;
  * usd-core's validators (UsdValidation, all registered, as usdchecker runs them) report no
    error; warnings are printed. A deliberately broken stage must make them report errors;
  * the usda and usdc stages hold the same prims, types, schemas, metadata and values.
Exits non-zero with a list of every failure.
"""

import json
import math
import os
import sys

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdSemantics, UsdShade, UsdValidation

TOLERANCE_M = 1e-3
POINT_LIGHT_RADIUS_M = 0.025  # crates/export/src/usd.rs
LEGACY = "SemanticsAPI:Semantics"


class Failures(list):
    def check(self, ok, message):
        if not ok:
            self.append(message)
        return ok


def api_schemas(prim):
    """Every applied schema name authored on the prim, known to usd-core or not
    (GetAppliedSchemas drops the legacy Isaac schema, which usd-core does not define)."""
    ops = prim.GetMetadata("apiSchemas")
    return list(ops.ApplyOperations([])) if ops else []


def labelled_prims(stage):
    found = {}
    for prim in stage.Traverse():
        if prim.HasAPI(UsdSemantics.LabelsAPI, "class") or LEGACY in api_schemas(prim):
            found[str(prim.GetPath())] = prim
    return found


def check_labels_and_bounds(stage, manifest, fail, name):
    expected = [(o["class"], o["instance_id"], o["min"], o["max"], o["room"]) for o in manifest["objects"]]
    doors = {d["id"]: d for d in manifest["doors"]}
    for t in manifest["thresholds"]:
        expected.append(("threshold", t["instance_id"], t["min"], t["max"], doors.get(t["door"], {}).get("rooms", [None])[0]))
    class_ids = {c: i + 1 for i, c in enumerate(
        ["sofa", "bed", "table", "chair", "bathtub", "basin", "computer", "plant", "lamp", "toy", "threshold"])}
    labelled = labelled_prims(stage)
    fail.check(len(labelled) == len(expected),
               f"{name}: {len(labelled)} labelled prims, manifest has {len(expected)} objects + thresholds")
    by_instance = {}
    for path, prim in labelled.items():
        attr = prim.GetAttribute("scenegen:instance_id")
        by_instance.setdefault(attr.Get() if attr else None, []).append(prim)
    xform_cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    for cls, instance_id, lo, hi, room in expected:
        prims = by_instance.get(instance_id, [])
        if not fail.check(len(prims) == 1, f"{name}: {len(prims)} prims for {cls} instance {instance_id}"):
            continue
        prim = prims[0]
        where = f"{name}: {prim.GetPath()}"
        labels = UsdSemantics.LabelsAPI(prim, "class").GetLabelsAttr().Get()
        fail.check(labels is not None and list(labels) == [cls], f"{where}: LabelsAPI class labels {labels}, want [{cls}]")
        fail.check(LEGACY in api_schemas(prim), f"{where}: {LEGACY} not applied")
        fail.check(prim.GetAttribute("semantic:Semantics:params:semanticType").Get() == "class", f"{where}: semanticType")
        fail.check(prim.GetAttribute("semantic:Semantics:params:semanticData").Get() == cls, f"{where}: semanticData")
        fail.check(prim.GetAttribute("scenegen:class_id").Get() == class_ids[cls], f"{where}: class_id")
        if room is not None:
            fail.check(prim.GetAttribute("scenegen:room").Get() == room, f"{where}: room")
        got_lo, got_hi = tight_world_bounds(prim, xform_cache)
        err = max(max(abs(got_lo[i] - lo[i]), abs(got_hi[i] - hi[i])) for i in range(3))
        fail.check(err <= TOLERANCE_M,
                   f"{where}: world bounds {list(got_lo)}..{list(got_hi)} vs manifest {lo}..{hi} ({err * 1e3:.3f} mm off)")
    return len(expected)


def tight_world_bounds(prim, xform_cache):
    """The axis-aligned box of every mesh point under `prim`, in world space.

    The manifest holds the tight box of the placed mesh. UsdGeom.BBoxCache's world bound is the
    aligned box of each local box after its transform, which is looser for an object turned by
    an angle that is not a multiple of 90 degrees, so compare points instead.
    """
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    for child in Usd.PrimRange(prim):
        if not child.IsA(UsdGeom.Mesh):
            continue
        to_world = xform_cache.GetLocalToWorldTransform(child)
        for p in UsdGeom.Mesh(child).GetPointsAttr().Get():
            w = to_world.Transform(Gf.Vec3d(p))
            lo = [min(lo[i], w[i]) for i in range(3)]
            hi = [max(hi[i], w[i]) for i in range(3)]
    return lo, hi


def check_lights(stage, manifest, fail, name):
    world = stage.GetDefaultPrim()
    variants = world.GetVariantSets().GetVariantSet("lighting")
    if not fail.check(sorted(variants.GetVariantNames()) == ["day", "night"], f"{name}: lighting variants"):
        return
    for group in ("day", "night"):
        variants.SetVariantSelection(group)
        want = {l["id"]: l for l in manifest["lights"] if l["group"] == group}
        got = {}
        for prim in stage.Traverse():
            if prim.HasAPI(UsdLux.LightAPI):
                got[prim.GetName()] = prim
        fail.check(sorted(got) == sorted(f"light_{i}" for i in want),
                   f"{name}: variant {group} activates {sorted(got)}, want {len(want)} {group} lights")
        for i, light in want.items():
            prim = got.get(f"light_{i}")
            if prim is None:
                continue
            api = UsdLux.LightAPI(prim)
            intensity = api.GetIntensityAttr().Get()
            kind = light["kind"]
            if kind == "point":
                ok = prim.IsA(UsdLux.SphereLight) and math.isclose(
                    intensity * math.pi * POINT_LIGHT_RADIUS_M ** 2, light["intensity"], rel_tol=1e-4)
            elif kind == "directional":
                ok = prim.IsA(UsdLux.DistantLight) and api.GetNormalizeAttr().Get() and math.isclose(
                    intensity, light["intensity"], rel_tol=1e-6)
            else:
                ok = prim.IsA(UsdLux.RectLight) and math.isclose(intensity, light["intensity"], rel_tol=1e-6)
            fail.check(ok, f"{name}: {prim.GetPath()} ({prim.GetTypeName()}, intensity {intensity}) does not carry "
                           f"{kind} light {i} ({light['intensity']} {light['unit']})")
    variants.SetVariantSelection("day")


def check_textures(stage, path, fail, name):
    folder = os.path.dirname(os.path.abspath(path))
    count = 0
    for prim in stage.Traverse():
        shader = UsdShade.Shader(prim)
        if shader and shader.GetIdAttr().Get() == "UsdUVTexture":
            asset = shader.GetInput("file").Get()
            count += 1
            fail.check(os.path.isfile(os.path.join(folder, asset.path)), f"{name}: texture {asset.path} missing")
    return count


VALIDATORS = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()


def validate(stage):
    errors = UsdValidation.ValidationContext(VALIDATORS).Validate(stage)
    return [e for e in errors if not e.HasNoError()]


def check_validation(stage, fail, name):
    found = validate(stage)
    for e in found:
        if e.GetType() == UsdValidation.ValidationErrorType.Error:
            fail.append(f"{name}: usd-core validation error: {e.GetErrorAsString()}")
        else:
            print(f"    {name}: usd-core validation {e.GetType().displayName}: {e.GetErrorAsString()}")


def validator_self_test(fail):
    """The validators must catch a stage that breaks the rules (no units, no up axis, an
    unbound material relationship), or a clean report proves nothing."""
    stage = Usd.Stage.CreateInMemory("broken.usda")
    mesh = UsdGeom.Mesh.Define(stage, "/World/mesh")
    stage.SetDefaultPrim(mesh.GetPrim().GetParent())
    mesh.GetPrim().CreateRelationship("material:binding").SetTargets(["/World/nowhere"])
    errors = [e for e in validate(stage) if e.GetType() == UsdValidation.ValidationErrorType.Error]
    fail.check(len(errors) >= 2, f"validator self-test: a broken stage gave only {len(errors)} errors")
    return len(errors)


def snapshot(stage):
    """Everything the stage says, in a comparable form (inactive prims included)."""
    out = {}
    for prim in Usd.PrimRange.Stage(stage, Usd.PrimAllPrimsPredicate):
        attrs = {}
        for attr in prim.GetAuthoredAttributes():
            value = attr.Get()
            if isinstance(value, Sdf.AssetPath):
                value = value.path  # the authored path; the resolved one names the folder
            conns = [str(p) for p in attr.GetConnections()]
            attrs[attr.GetName()] = (str(attr.GetTypeName()), repr(value), conns,
                                     attr.GetMetadata("interpolation"))
        rels = {r.GetName(): [str(t) for t in r.GetTargets()] for r in prim.GetAuthoredRelationships()}
        out[str(prim.GetPath())] = (prim.GetTypeName(), api_schemas(prim), prim.IsActive(),
                                    repr(prim.GetCustomData()), attrs, rels)
    layer_meta = tuple(repr(stage.GetMetadata(k)) for k in ("metersPerUnit", "upAxis", "defaultPrim"))
    return layer_meta, out


def compare(a, b, fail, name):
    meta_a, prims_a = snapshot(a)
    meta_b, prims_b = snapshot(b)
    fail.check(meta_a == meta_b, f"{name}: stage metadata differs {meta_a} vs {meta_b}")
    fail.check(sorted(prims_a) == sorted(prims_b), f"{name}: prim paths differ")
    diffs = [p for p in prims_a if p in prims_b and prims_a[p] != prims_b[p]]
    fail.check(not diffs, f"{name}: {len(diffs)} prims differ, first {diffs[:3]}")
    return len(prims_a)


def short(path):
    return os.path.join(os.path.basename(os.path.dirname(path)), os.path.basename(path))


def main(argv):
    usda, usdc = argv[1], argv[2]
    manifest_path = os.path.join(os.path.dirname(usda), "scene.json")
    with open(manifest_path, encoding="utf-8") as f:
        manifest = json.load(f)
    fail = Failures()
    stages = {}
    for path in (usda, usdc):
        name = short(path)
        stage = Usd.Stage.Open(path)
        if not fail.check(stage is not None, f"{name}: usd-core cannot open it"):
            continue
        stages[path] = stage
        fail.check(UsdGeom.GetStageMetersPerUnit(stage) == 1.0, f"{name}: metersPerUnit")
        fail.check(UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z, f"{name}: upAxis")
        fail.check(stage.GetDefaultPrim() and stage.GetDefaultPrim().GetPath() == Sdf.Path("/World"), f"{name}: defaultPrim")
        labelled = check_labels_and_bounds(stage, manifest, fail, name)
        check_lights(stage, manifest, fail, name)
        textures = check_textures(stage, path, fail, name)
        check_validation(stage, fail, name)
        meshes = sum(1 for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
        print(f"  {name}: {labelled} labelled objects/thresholds, {meshes} meshes, {textures} textures, "
              f"{len(manifest['lights'])} lights, validated with {len(VALIDATORS)} validators")
    if len(stages) == 2:
        prims = compare(stages[usda], stages[usdc], fail, f"{short(usda)} vs usdc")
        print(f"  usda and usdc hold the same {prims} prims")
    errors = validator_self_test(fail)
    print(f"  validator self-test: a broken stage gives {errors} errors (of the {len(VALIDATORS)} validators, the "
          "usdz ones act only on .usdz packages and the physics/skel ones only on prims with those schemas, "
          "none here)")
    for message in fail:
        print(f"FAIL {message}", file=sys.stderr)
    return 1 if fail else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
