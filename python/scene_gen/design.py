"""Cameras judged and data made: the evaluator and the dataset writer."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Callable, Dict, Iterable, List, Optional, Sequence, Tuple, Union

from . import _native
from .camera import CameraLike, camera as _camera
from .frames import Progress
from .house import Envelope, PathLike, house_kwargs

Seeds = Union[int, str, range, Iterable[int]]
"""House seeds: one seed, ``"A..B"`` (B excluded), ``"A..=B"``, a ``range`` or a list."""


def _seed_list(seeds: Seeds) -> List[int]:
    if isinstance(seeds, int):
        return [seeds]
    if isinstance(seeds, str):
        return _native.seeds(seeds)
    return [int(s) for s in seeds]


def _seed_text(seeds: Seeds) -> str:
    """A contiguous seed set as ``A..=B`` (datasets cover a range of seeds)."""
    if isinstance(seeds, str):
        return seeds
    listed = _seed_list(seeds)
    if not listed or listed != list(range(listed[0], listed[0] + len(listed))):
        raise ValueError("seeds: a dataset covers a contiguous range of seeds (A..B)")
    return f"{listed[0]}..={listed[-1]}"


def evaluate(
    camera: CameraLike,
    seeds: Seeds = range(1),
    frames: Optional[int] = None,
    max_width: Optional[Union[int, str]] = None,
    detector: Optional[str] = None,
    envelope: Optional[Envelope] = None,
    min_room: Optional[float] = None,
    rooms: Optional[PathLike] = None,
    furniture: Optional[PathLike] = None,
    progress: Optional[Progress] = None,
) -> Dict[str, Any]:
    """Scores ``camera`` walking the houses of ``seeds`` by day and by night, as
    ``scene-gen evaluate --json`` does: threshold sightings in time, detection AP@0.5 and ORB
    tracking per scenario, and the fitness (``result["fitness"]["mean"]``). ``frames`` anchor
    frames per house and ``max_width`` the binned width default to the evaluator's (``"native"``
    judges every pixel of the sensor); ``detector``
    is ``"cnn"`` (the learned detector, the default), ``"model"`` (the fast detectability model)
    or a plug-in command (the plug-in protocol)."""
    result = _native.evaluate(
        _camera(camera),
        _seed_list(seeds),
        frames=frames,
        max_width=max_width,
        detector=detector,
        progress=progress,
        **house_kwargs(envelope, min_room, rooms, furniture),
    )
    evaluation: Dict[str, Any] = json.loads(result)
    return evaluation


class Dataset:
    """A dataset folder (images, depth, masks, classes, normals, labels, COCO annotations) and
    the spec that fixes every byte in it, as ``scene-gen dataset`` makes it.

    The work splits by seed: :meth:`run_seed` in any process that opened the same folder gives
    the same bytes, and :meth:`merge` writes the COCO files once every seed is done (see
    ``scene_gen.ray`` for a Ray cluster)."""

    def __init__(
        self,
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
        raw: bool = False,
    ) -> None:
        self._native = _native.Dataset(
            os.fspath(out),
            _camera(camera),
            _seed_text(seeds),
            lighting=lighting,
            frames=frames,
            every=every,
            max_width=max_width,
            quality=quality,
            raw=raw,
            **house_kwargs(envelope, min_room, rooms, furniture),
        )

    @classmethod
    def open(cls, out: PathLike) -> "Dataset":
        """The dataset whose ``dataset.json`` is in ``out`` (made by another process)."""
        dataset = cls.__new__(cls)
        dataset._native = _native.Dataset.open(os.fspath(out))
        return dataset

    @property
    def out(self) -> Path:
        return Path(self._native.out)

    @property
    def seeds(self) -> List[int]:
        return self._native.seeds()

    @property
    def image_size(self) -> Tuple[int, int]:
        """(width, height) in pixels."""
        return self._native.image_size()

    @property
    def spec(self) -> Dict[str, Any]:
        """``dataset.json``."""
        spec: Dict[str, Any] = json.loads(self._native.spec_json())
        return spec

    def init(self) -> None:
        """Creates the folder and writes ``dataset.json`` (once)."""
        self._native.init()

    def run_seed(self, seed: int, progress: Optional[Progress] = None) -> Dict[str, int]:
        """Makes every missing frame of the house ``seed`` and its fragment; returns counts of
        frames, those rendered now and those already there."""
        return dict(zip(("frames", "rendered", "skipped"), self._native.run_seed(seed, progress)))

    def run_shard(self, index: int = 0, count: int = 1, progress: Optional[Progress] = None) -> Dict[str, int]:
        """Makes the seeds numbered ``index`` mod ``count`` in the range."""
        return dict(zip(("frames", "rendered", "skipped"), self._native.run_shard(index, count, progress)))

    def missing_seeds(self) -> List[int]:
        """Seeds whose fragment is not written yet."""
        return self._native.missing_seeds()

    def merge(self) -> List[Path]:
        """Writes ``annotations/instances_<lighting>.json`` from the seeds' fragments (every seed
        must be done); returns their paths."""
        return [Path(p) for p in self._native.merge()]

    def __repr__(self) -> str:
        return repr(self._native)


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
    raw: bool = False,
) -> Dataset:
    """Makes the whole dataset in ``out``, byte for byte as ``scene-gen dataset`` does with the
    same options (a rerun resumes), and merges its COCO files. ``frames`` frames per house
    evenly spaced along the walk, or every ``every``-th pose, or (neither) every pose; ``raw``
    also writes the raw captures under ``raw/``."""
    dataset = Dataset(
        out, camera, seeds, lighting, frames, every, max_width, quality, envelope, min_room, rooms, furniture, raw
    )
    dataset.init()
    dataset.run_shard(0, 1, progress)
    dataset.merge()
    return dataset


ScoreBatch = Callable[[str, List[Dict[str, Any]]], Sequence[Tuple[float, float, float]]]
"""Scores a generation's candidates: called as ``score_batch(config_json, cameras)`` with the
run's configuration (JSON text) and the candidates' camera specs (dicts), it returns
``(day, night, fitness)`` per candidate, in order, as :func:`score_candidates` gives them."""


def optimize_config(
    config: Optional[PathLike] = None,
    envelope: Optional[Envelope] = None,
    min_room: Optional[float] = None,
    rooms: Optional[PathLike] = None,
    furniture: Optional[PathLike] = None,
) -> str:
    """The configuration of an optimizer run as JSON: the TOML file ``config`` (default: the
    embedded ``optimize.toml``) with the house options given over its ``[house]``."""
    path = None if config is None else os.fspath(config)
    return _native.optimize_config(path, **house_kwargs(envelope, min_room, rooms, furniture))


def score_candidates(config_json: str, cameras: List[Dict[str, Any]]) -> List[Tuple[float, float, float]]:
    """``(day, night, fitness)`` of each camera spec under the run configuration
    ``config_json``, exactly as ``scene-gen optimize`` scores a candidate (what a worker of a
    distributed run calls)."""
    return _native.score_candidates(config_json, [json.dumps(c) for c in cameras])


def _native_batch(
    score_batch: ScoreBatch, config_json: str
) -> Callable[[List[str]], List[Tuple[float, float, float]]]:
    """``score_batch`` as the native optimizer calls it (candidates as JSON text)."""

    def batch(specs: List[str]) -> List[Tuple[float, float, float]]:
        scores = score_batch(config_json, [json.loads(c) for c in specs])
        return [(float(day), float(night), float(fitness)) for day, night, fitness in scores]

    return batch


def optimize(
    out: PathLike,
    config: Optional[PathLike] = None,
    method: str = "ga",
    envelope: Optional[Envelope] = None,
    min_room: Optional[float] = None,
    rooms: Optional[PathLike] = None,
    furniture: Optional[PathLike] = None,
    progress: Optional[Progress] = None,
    score_batch: Optional[ScoreBatch] = None,
    stop_after: Optional[int] = None,
) -> Dict[str, Any]:
    """Runs (or resumes) the camera-design optimizer in the folder ``out``, as
    ``scene-gen optimize --config CONFIG --method METHOD`` does, writing the same files
    (``state.json``, ``candidates.csv``, ``generations.csv``, ``best_camera.toml``,
    ``curve.png``). ``method`` is ``ga`` (the genetic algorithm) or ``random`` (the baseline at
    equal budget). ``score_batch`` scores each generation's candidates elsewhere (see
    :data:`ScoreBatch`; ``scene_gen.ray.optimize`` uses a Ray cluster); by default this
    process scores them. ``stop_after`` stops after that many evaluations (run again to
    resume). ``progress(evaluations, budget)`` is told after every candidate. Returns the
    summary: ``complete``, ``evaluations``, ``evaluated_now``, ``best`` (scores) and
    ``best_camera`` (its spec)."""
    config_json = optimize_config(config, envelope, min_room, rooms, furniture)
    batch = None if score_batch is None else _native_batch(score_batch, config_json)
    summary: Dict[str, Any] = json.loads(
        _native.optimize(os.fspath(out), config_json, method, score_batch=batch, progress=progress, stop_after=stop_after)
    )
    return summary


__all__ = [
    "Dataset",
    "ScoreBatch",
    "Seeds",
    "evaluate",
    "optimize",
    "optimize_config",
    "score_candidates",
    "write_dataset",
]
