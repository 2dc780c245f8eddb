"""Writes a scene-gen USD stage with usd-core (pxr) from the Rust exporter's interchange.

    python write_usd.py SCRATCH_DIR OUTPUT.usda|OUTPUT.usdc

SCRATCH_DIR holds interchange.json (schema scene-gen/usd-interchange/1: every prim, material and
light, laid out by crates/export/src/usd.rs) and geometry.bin (little-endian f32 and u32 vertex arrays
the meshes point into by byte offset and element count). This script makes no layout decisions:
it transcribes the plan with the USD schemas (UsdGeom, UsdShade UsdPreviewSurface, UsdLux,
UsdSemantics) and saves the layer; the layer format follows the output's extension.

The scene-gen binary embeds this file and runs it from a scratch folder, so it must depend on
nothing but the standard library and usd-core.
"""

import json
import os
import sys

# Exit status 3 tells the Rust side that usd-core is missing (it then prints the install command).
USD_CORE_MISSING = 3
try:
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdSemantics, UsdShade, Vt
except ImportError as error:
    print(f"cannot import usd-core: {error}", file=sys.stderr)
    sys.exit(USD_CORE_MISSING)

SCHEMA = "scene-gen/usd-interchange/1"

# Isaac Sim's legacy semantics schema (multiple-apply, instance name "Semantics"). It is not in
# usd-core, so it is applied by name and its attributes are authored as Isaac Sim writes them
# (non-custom strings).
LEGACY_SEMANTICS = "SemanticsAPI:Semantics"
LEGACY_TYPE_ATTR = "semantic:Semantics:params:semanticType"
LEGACY_DATA_ATTR = "semantic:Semantics:params:semanticData"


def matrix(values):
    """A column-major 4x4 (glam) as Gf.Matrix4d: USD stores row vectors, so the same 16 numbers
    in row-major order are the same transform."""
    return Gf.Matrix4d(*[float(v) for v in values])


class Arrays:
    """Views into geometry.bin."""

    def __init__(self, data):
        if sys.byteorder != "little":
            raise SystemExit("write_usd.py: geometry.bin is little-endian; this machine is not")
        self.view = memoryview(data)

    def floats(self, span, per_element):
        start = span["offset"]
        return self.view[start : start + 4 * per_element * span["count"]].cast("f")

    def vec3f(self, span):
        return Vt.Vec3fArray.FromBuffer(self.floats(span, 3))

    def vec2f(self, span):
        return Vt.Vec2fArray.FromBuffer(self.floats(span, 2))

    def ints(self, span):
        start = span["offset"]
        # u32 indices, read as i32: a mesh never has 2^31 vertices.
        return Vt.IntArray.FromBuffer(self.view[start : start + 4 * span["count"]].cast("i"))


def define_xform(stage, spec):
    if spec["type"] == "Scope":
        return UsdGeom.Scope.Define(stage, spec["path"]).GetPrim()
    xform = UsdGeom.Xform.Define(stage, spec["path"])
    if spec.get("transform") is not None:
        xform.AddTransformOp().Set(matrix(spec["transform"]))
    prim = xform.GetPrim()
    if spec.get("room") is not None:
        room_id, room_type = spec["room"]
        prim.SetCustomDataByKey("scenegen:room_id", int(room_id))
        prim.SetCustomDataByKey("scenegen:room_type", room_type)
    if spec.get("label") is not None:
        label(prim, spec["label"])
    return prim


def label(prim, spec):
    """Both semantics forms, plus class and instance ids, on a labelled root prim."""
    labels = UsdSemantics.LabelsAPI.Apply(prim, "class")
    labels.CreateLabelsAttr().Set(Vt.TokenArray([spec["class"]]))
    prim.AddAppliedSchema(LEGACY_SEMANTICS)
    prim.CreateAttribute(LEGACY_TYPE_ATTR, Sdf.ValueTypeNames.String, custom=False).Set("class")
    prim.CreateAttribute(LEGACY_DATA_ATTR, Sdf.ValueTypeNames.String, custom=False).Set(spec["class"])
    prim.CreateAttribute("scenegen:class_id", Sdf.ValueTypeNames.Int, custom=True).Set(spec["class_id"])
    prim.CreateAttribute("scenegen:instance_id", Sdf.ValueTypeNames.Int, custom=True).Set(spec["instance_id"])
    if spec.get("room") is not None:
        prim.CreateAttribute("scenegen:room", Sdf.ValueTypeNames.Int, custom=True).Set(spec["room"])


def define_material(stage, spec, textures):
    material = UsdShade.Material.Define(stage, spec["path"])
    surface = UsdShade.Shader.Define(stage, spec["path"] + "/PreviewSurface")
    surface.CreateIdAttr("UsdPreviewSurface")
    r, g, b, a = spec["base_color"]
    surface.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(spec["metallic"])
    surface.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(spec["roughness"])
    surface.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(a)
    diffuse = surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
    if spec.get("texture") is None:
        diffuse.Set(Gf.Vec3f(r, g, b))
    else:
        reader = UsdShade.Shader.Define(stage, spec["path"] + "/StReader")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
        st = reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)
        texture = UsdShade.Shader.Define(stage, spec["path"] + "/BaseColorTexture")
        texture.CreateIdAttr("UsdUVTexture")
        texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath("./" + textures[spec["texture"]]))
        texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(st)
        texture.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("repeat")
        texture.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("repeat")
        texture.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB")
        texture.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(r, g, b, a))
        diffuse.ConnectToSource(texture.CreateOutput("rgb", Sdf.ValueTypeNames.Float3))
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    return material


def define_mesh(stage, spec, arrays, materials):
    mesh = UsdGeom.Mesh.Define(stage, spec["path"])
    points = arrays.vec3f(spec["points"])
    mesh.CreatePointsAttr(points)
    mesh.CreateExtentAttr(UsdGeom.PointBased.ComputeExtent(points))
    indices = arrays.ints(spec["indices"])
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray(len(indices) // 3, 3))
    mesh.CreateFaceVertexIndicesAttr(indices)
    mesh.CreateNormalsAttr(arrays.vec3f(spec["normals"]))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
    st.Set(arrays.vec2f(spec["st"]))
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(materials[spec["material"]])


def define_light(stage, spec):
    kind = spec["type"]
    path = spec["path"]
    if kind == "DistantLight":
        light = UsdLux.DistantLight.Define(stage, path)
        light.CreateAngleAttr(spec["angle"])
    elif kind == "SphereLight":
        light = UsdLux.SphereLight.Define(stage, path)
        light.CreateRadiusAttr(spec["radius"])
    elif kind == "RectLight":
        light = UsdLux.RectLight.Define(stage, path)
        light.CreateWidthAttr(spec["width"])
        light.CreateHeightAttr(spec["height"])
    else:
        raise SystemExit(f"write_usd.py: unknown light type {kind!r} at {path}")
    light.AddTransformOp().Set(matrix(spec["transform"]))
    light.CreateIntensityAttr(spec["intensity"])
    light.CreateNormalizeAttr(bool(spec["normalize"]))
    light.CreateColorAttr(Gf.Vec3f(*spec["color"]))
    prim = light.GetPrim()
    prim.CreateAttribute("scenegen:intensity", Sdf.ValueTypeNames.Float, custom=True).Set(spec["source_intensity"])
    prim.CreateAttribute("scenegen:unit", Sdf.ValueTypeNames.String, custom=True).Set(spec["source_unit"])


def lighting_variants(stage, world, groups):
    """Variant set `lighting` on /World: each variant deactivates the other group's lights."""
    variants = world.GetVariantSets().AddVariantSet("lighting")
    for name, _ in groups:
        variants.AddVariant(name)
    for name, _ in groups:
        variants.SetVariantSelection(name)
        with variants.GetVariantEditContext():
            for other, path in groups:
                stage.OverridePrim(path).SetActive(other == name)
    variants.SetVariantSelection(groups[0][0])


def main(argv):
    if len(argv) != 3:
        raise SystemExit("usage: write_usd.py SCRATCH_DIR OUTPUT.usda|OUTPUT.usdc")
    scratch, output = argv[1], argv[2]
    with open(os.path.join(scratch, "interchange.json"), encoding="utf-8") as f:
        plan = json.load(f)
    if plan.get("schema") != SCHEMA:
        raise SystemExit(f"write_usd.py: interchange schema {plan.get('schema')!r}, expected {SCHEMA!r}")
    with open(os.path.join(scratch, "geometry.bin"), "rb") as f:
        arrays = Arrays(f.read())

    stage = Usd.Stage.CreateNew(output)
    UsdGeom.SetStageUpAxis(stage, plan["up_axis"])
    UsdGeom.SetStageMetersPerUnit(stage, plan["meters_per_unit"])
    stage.SetMetadata("comment", f"scene-gen seed {plan['seed']}")
    prims = {spec["path"]: define_xform(stage, spec) for spec in plan["prims"]}
    world = prims["/" + plan["default_prim"]]
    stage.SetDefaultPrim(world)
    materials = {spec["path"]: define_material(stage, spec, plan["textures"]) for spec in plan["materials"]}
    for spec in plan["meshes"]:
        define_mesh(stage, spec, arrays, materials)
    for spec in plan["lights"]:
        define_light(stage, spec)
    lighting_variants(stage, world, plan["light_groups"])
    stage.GetRootLayer().Save()


if __name__ == "__main__":
    main(sys.argv)
