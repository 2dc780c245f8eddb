"""Houses from Python are the command line's houses: same manifest, same exported bytes."""

import json

import pytest

import scene_gen as sg
from conftest import tree_bytes


def test_generate_matches_the_command_line(cli, tmp_path):
    cli("--seed", 3, "--envelope", "12x10x3", "--min-room", 4, "--format", "obj", "--out", tmp_path / "cli")
    scene = sg.generate(3, envelope=(12, 10, 3), min_room=4)
    written = scene.export(tmp_path / "py", format="obj")
    assert {p.name for p in written} >= {"scene.obj", "scene.json", "plan.png"}
    assert tree_bytes(tmp_path / "py") == tree_bytes(tmp_path / "cli")
    assert scene.manifest == json.loads((tmp_path / "cli" / "scene.json").read_text())


def test_semantics_as_objects():
    scene = sg.generate(7)
    assert scene.seed == 7
    assert len(scene.rooms) >= 2 and all(r.area_m2 >= 5 * 5 * 0.9 for r in scene.rooms)
    assert len(scene.thresholds) == len(scene.doors) > 0
    classes = {o.class_name for o in scene.objects}
    assert classes <= set(sg.CATEGORIES.values())
    for o in scene.objects:
        assert sg.CATEGORIES[o.category_id] == o.class_name
        assert all(lo <= hi for lo, hi in zip(o.min, o.max))
    ids = [o.instance_id for o in scene.objects] + [t.instance_id for t in scene.thresholds]
    assert len(set(ids)) == len(ids) and 0 not in ids


def test_glb_export_is_the_command_lines(cli, tmp_path):
    cli("--seed", 0, "--out", tmp_path / "cli")
    sg.generate(0).export(tmp_path / "py")
    assert (tmp_path / "py" / "scene.glb").read_bytes() == (tmp_path / "cli" / "scene.glb").read_bytes()


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"envelope": "1x1x1"}, "envelope"),
        ({"envelope": "fifteen"}, "envelope"),
        ({"min_room": -2}, "min"),
        ({"rooms": "/nonexistent/rooms"}, "/nonexistent/rooms"),
    ],
)
def test_bad_house_options_raise_value_error(kwargs, words):
    with pytest.raises(ValueError, match=words):
        sg.generate(1, **kwargs)


def test_unknown_export_format(tmp_path):
    with pytest.raises(ValueError, match="unknown scene format"):
        sg.generate(0).export(tmp_path, format="fbx")
    assert not any(tmp_path.iterdir())
