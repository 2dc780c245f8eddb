"""The optimizer from Python: the command line's files, however the candidates are scored."""

import pytest

import scene_gen as sg
from scene_gen.design import score_candidates
from conftest import tree_bytes

TINY = """
seed = 3
[ga]
population = 4
generations = 2
parents = 2
elites = 1
[evaluation]
seeds = [1]
frames_per_scene = 6
max_width_px = 64
"""


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    path = tmp_path_factory.mktemp("config") / "tiny.toml"
    path.write_text(TINY)
    return path


@pytest.fixture(scope="module")
def reference(cli, config, tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "run"
    cli("optimize", "--config", config, "--out", out)
    return tree_bytes(out)


def test_optimize_matches_the_command_line(config, reference, tmp_path):
    calls = []
    summary = sg.optimize(tmp_path / "run", config=config, progress=lambda done, budget: calls.append((done, budget)))
    assert tree_bytes(tmp_path / "run") == reference
    assert summary["complete"] and summary["evaluations"] == summary["evaluated_now"] == 7
    # One report per candidate (the elite of generation 1 is not evaluated again).
    assert len(calls) == 8 and calls[-1] == (7, 7) and calls == sorted(calls)
    assert summary["best_camera"]["sensor"] and summary["best"]["fitness"] > 0
    assert b"fitness 0 (day 0, night 0)" not in reference["best_camera.toml"]


def test_generations_scored_elsewhere_give_the_same_files(config, reference, tmp_path):
    batches = []

    def score_batch(config_json, cameras):
        batches.append(len(cameras))
        # As workers would: one call per candidate, results put back in order.
        return [score_candidates(config_json, [camera])[0] for camera in cameras]

    sg.optimize(tmp_path / "run", config=config, score_batch=score_batch)
    assert batches == [4, 3]
    assert tree_bytes(tmp_path / "run") == reference


def test_a_stopped_run_resumes_to_the_same_files(config, reference, tmp_path):
    first = sg.optimize(tmp_path / "run", config=config, stop_after=5)
    assert not first["complete"] and first["evaluated_now"] == 5
    second = sg.optimize(tmp_path / "run", config=config)
    assert second["complete"] and second["evaluated_now"] == 2
    assert tree_bytes(tmp_path / "run") == reference


def test_bad_optimizer_input(config, tmp_path):
    with pytest.raises(ValueError, match="method"):
        sg.optimize(tmp_path / "a", config=config, method="annealing")
    bad = tmp_path / "bad.toml"
    bad.write_text("[ga]\npopulation = 0\n")
    with pytest.raises(ValueError, match="bad.toml"):
        sg.optimize(tmp_path / "b", config=bad)
    with pytest.raises(RuntimeError, match="score_batch"):
        sg.optimize(tmp_path / "c", config=config, score_batch=lambda cfg, cams: [(1.0, 1.0)] * len(cams))
    sg.optimize(tmp_path / "d", config=config, stop_after=1)
    with pytest.raises(ValueError, match="method"):
        sg.optimize(tmp_path / "d", config=config, method="random")
