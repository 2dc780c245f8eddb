"""The evaluator and the dataset writer from Python give the command line's results."""

import json

import pytest

import scene_gen as sg
from conftest import tree_bytes

CAMERA = "IMX174,focal_mm=3"


def test_evaluate_matches_the_command_line(cli):
    args = ["--camera", CAMERA, "--seeds", "0..2", "--frames", 2, "--max-width", 96, "--min-room", 4.5]
    expected = json.loads(cli("evaluate", *args, "--json"))
    calls = []
    result = sg.evaluate(CAMERA, seeds=range(2), frames=2, max_width=96, min_room=4.5,
                         progress=lambda done, planned: calls.append((done, planned)))
    assert result == expected
    assert 0 <= result["fitness"]["mean"] and result["seeds"] == [0, 1]
    assert result["config"]["detector"] == "cnn"  # the learned detector is the default
    assert calls and calls[-1][0] == calls[-1][1] == len(calls)


def test_evaluate_refuses_bad_input():
    with pytest.raises(ValueError, match="no seeds"):
        sg.evaluate(CAMERA, seeds=[])
    with pytest.raises(ValueError, match="frames"):
        sg.evaluate(CAMERA, frames=0)
    with pytest.raises(ValueError, match="holds no seed"):
        sg.evaluate(CAMERA, seeds="3..1")
    with pytest.raises(ValueError, match="expected A..B"):
        sg.evaluate(CAMERA, seeds="zero..two")
    with pytest.raises(ValueError, match="ceiling"):
        sg.evaluate("IMX174,height_m=3", frames=1)


def test_evaluate_judges_the_native_width_as_the_command_line(cli):
    args = ["--camera", "PYTHON300,focal_mm=3", "--frames", 1, "--max-width", "native"]
    expected = json.loads(cli("evaluate", *args, "--json"))
    result = sg.evaluate("PYTHON300,focal_mm=3", frames=1, max_width="native")
    assert result == expected
    assert result["config"]["max_width_px"] == "native"
    with pytest.raises(ValueError, match="max_width"):
        sg.evaluate(CAMERA, frames=1, max_width="wide")
    with pytest.raises(ValueError, match="max_width"):
        sg.evaluate(CAMERA, frames=1, max_width=0)


DATASET = dict(seeds="0..2", frames=3, max_width=96, quality="preview")


def test_write_dataset_matches_the_command_line(cli, tmp_path):
    cli("dataset", "--seeds", "0..2", "--camera", CAMERA, "--frames", 3, "--max-width", 96,
        "--quality", "preview", "--out", tmp_path / "cli")
    calls = []
    dataset = sg.write_dataset(tmp_path / "py", CAMERA, progress=lambda d, p: calls.append(d), **DATASET)
    assert tree_bytes(tmp_path / "py") == tree_bytes(tmp_path / "cli")
    assert dataset.missing_seeds() == [] and dataset.seeds == [0, 1]
    assert dataset.image_size == sg.camera(CAMERA).resolution(96) == (96, 60)
    assert len(calls) == 2 * 3


def test_seeds_made_apart_merge_to_the_same_bytes(tmp_path):
    sg.write_dataset(tmp_path / "whole", CAMERA, **DATASET)
    made = sg.Dataset(tmp_path / "apart", CAMERA, **DATASET)
    made.init()
    for seed in reversed(made.seeds):
        # Each seed as another process would make it: from the folder's dataset.json alone.
        report = sg.Dataset.open(tmp_path / "apart").run_seed(seed)
        assert report["frames"] == report["rendered"] == 3
    assert made.missing_seeds() == []
    made.merge()
    assert tree_bytes(tmp_path / "apart") == tree_bytes(tmp_path / "whole")
    assert sg.Dataset.open(tmp_path / "apart").run_seed(0) == {"frames": 3, "rendered": 0, "skipped": 3}


def test_dataset_refuses_other_settings_and_strangers(tmp_path):
    sg.write_dataset(tmp_path / "ds", CAMERA, **DATASET)
    with pytest.raises(ValueError, match="other settings"):
        sg.Dataset(tmp_path / "ds", CAMERA, **{**DATASET, "frames": 4})
    with pytest.raises(ValueError, match="not in this dataset"):
        sg.Dataset.open(tmp_path / "ds").run_seed(9)
    with pytest.raises(ValueError, match="dataset.json"):
        sg.Dataset.open(tmp_path / "nowhere")
    with pytest.raises(ValueError, match="contiguous"):
        sg.Dataset(tmp_path / "x", CAMERA, seeds=[0, 2])
