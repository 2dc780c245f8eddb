"""Scale-out on Ray: a local two-worker cluster (loopback only) makes the bytes of a single process."""

import os

import pytest

# Ray reads this when imported: a Linux node then binds its services to 127.0.0.1 only.
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
ray = pytest.importorskip("ray")

import scene_gen as sg  # noqa: E402
import scene_gen.ray as sgr  # noqa: E402
from conftest import tree_bytes  # noqa: E402
from test_optimize import TINY  # noqa: E402

CAMERA = "IMX174,focal_mm=3"
DATASET = dict(seeds="0..3", frames=2, max_width=64, quality="preview", lighting="both")


@pytest.fixture(scope="module", autouse=True)
def cluster():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    assert [node["NodeManagerAddress"] for node in ray.nodes()] == ["127.0.0.1"], "not on loopback"
    yield
    ray.shutdown()


def test_dataset_seeds_as_ray_tasks(tmp_path):
    sg.write_dataset(tmp_path / "one", CAMERA, **DATASET)
    seen = []
    dataset = sgr.write_dataset(tmp_path / "ray", CAMERA, progress=lambda d, n: seen.append((d, n)), **DATASET)
    assert seen[-1] == (3, 3) and dataset.missing_seeds() == []
    assert tree_bytes(tmp_path / "ray") == tree_bytes(tmp_path / "one")


def test_optimizer_generations_as_ray_tasks(tmp_path):
    config = tmp_path / "tiny.toml"
    config.write_text(TINY)
    sg.optimize(tmp_path / "one", config=config)
    summary = sgr.optimize(tmp_path / "ray", config=config)
    assert summary["complete"] and summary["evaluated_now"] == 7
    assert tree_bytes(tmp_path / "ray") == tree_bytes(tmp_path / "one")
