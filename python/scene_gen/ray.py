"""Scale-out on a Ray cluster: dataset seeds and optimizer generations as Ray tasks.

Both give the bytes a single process gives: a dataset seed's files depend only on the folder's
``dataset.json`` and the seed, and a candidate's score only on the run's configuration and its
camera, so it does not matter which worker made what or in which order the results came back.

    import scene_gen.ray as sgr
    sgr.write_dataset("/shared/ds", "IMX174,focal_mm=4", seeds="0..1000", every=4)
    sgr.optimize("/shared/runs/ga", config="optimize.toml")

``address`` is passed to ``ray.init`` when Ray is not initialised yet (``None``: the cluster
of ``RAY_ADDRESS``, or a new local one; ``"auto"``: the running cluster this machine belongs
to). A dataset's folder must be on a file system every worker sees under the same path (NFS,
a cluster file system, a mounted bucket): workers write their seeds' files there and the
driver merges them. An optimizer run's folder is written by the driver only.

Each task runs the Rust code on as many threads as the worker process has cores
(``num_cpus`` per task: Ray's scheduling share; set ``RAYON_NUM_THREADS`` in the workers'
environment to bound the threads of each).
"""

from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple

from . import design
from .camera import CameraLike
from .design import Dataset, Seeds
from .frames import Progress
from .house import Envelope, PathLike

try:
    import ray as _ray
except ImportError as e:  # pragma: no cover - exercised only without Ray
    raise ImportError("scene_gen.ray needs Ray: pip install 'ray>=2.9' (or .[ray] from the repository)") from e


def _init(address: Optional[str]) -> None:
    if not _ray.is_initialized():
        _ray.init(address=address)


def _run_seed(out: str, seed: int) -> Tuple[int, Dict[str, int]]:
    return seed, design.Dataset.open(out).run_seed(seed)


def _score(config_json: str, camera: Dict[str, Any]) -> Tuple[float, float, float]:
    (score,) = design.score_candidates(config_json, [camera])
    return score


def _gather(refs: List[Any], progress: Optional[Progress]) -> List[Any]:
    """The results of `refs` in their order, reporting each as it finishes."""
    pending = list(refs)
    while pending:
        done, pending = _ray.wait(pending, num_returns=1)
        _ray.get(done)  # Raises a task's exception at once.
        if progress is not None:
            progress(len(refs) - len(pending), len(refs))
    return list(_ray.get(refs))


def write_dataset(
    out: PathLike,
    camera: CameraLike,
    seeds: Seeds,
    lighting: str = "both",
    frames: Optional[int] = None,
    every: Optional[int] = None,
    max_width: Optional[int] = None,
    quality: str = "standard",
    envelope: Optional[Envelope] = None,
    min_room: Optional[float] = None,
    rooms: Optional[PathLike] = None,
    furniture: Optional[PathLike] = None,
    progress: Optional[Progress] = None,
    address: Optional[str] = None,
    num_cpus: float = 1,
    raw: bool = False,
) -> Dataset:
    """:func:`scene_gen.write_dataset` with one Ray task per seed still missing (a rerun
    resumes), then the merge on the driver. ``progress(seeds_done, seeds)``."""
    dataset = Dataset(
        out, camera, seeds, lighting, frames, every, max_width, quality, envelope, min_room, rooms, furniture, raw
    )
    dataset.init()
    _init(address)
    task = _ray.remote(num_cpus=num_cpus)(_run_seed)
    folder = os.fspath(dataset.out.resolve())
    _gather([task.remote(folder, seed) for seed in dataset.missing_seeds()], progress)
    dataset.merge()
    return dataset


def score_batch_on_ray(num_cpus: float = 1) -> design.ScoreBatch:
    """A :data:`scene_gen.design.ScoreBatch` that scores each candidate as a Ray task."""

    def score_batch(config_json: str, cameras: List[Dict[str, Any]]) -> Sequence[Tuple[float, float, float]]:
        task = _ray.remote(num_cpus=num_cpus)(_score)
        config_ref = _ray.put(config_json)
        return _gather([task.remote(config_ref, c) for c in cameras], None)

    return score_batch


def optimize(
    out: PathLike,
    config: Optional[PathLike] = None,
    method: str = "ga",
    envelope: Optional[Envelope] = None,
    min_room: Optional[float] = None,
    rooms: Optional[PathLike] = None,
    furniture: Optional[PathLike] = None,
    progress: Optional[Progress] = None,
    stop_after: Optional[int] = None,
    address: Optional[str] = None,
    num_cpus: float = 1,
) -> Dict[str, Any]:
    """:func:`scene_gen.optimize` with every generation's candidates scored as Ray tasks (one
    per candidate); the driver keeps the run folder. Same files as a single process."""
    _init(address)
    return design.optimize(
        out, config, method, envelope, min_room, rooms, furniture, progress, score_batch_on_ray(num_cpus), stop_after
    )


__all__ = ["optimize", "score_batch_on_ray", "write_dataset"]
