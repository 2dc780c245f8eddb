"""Houses: generation, their semantics as Python objects, and export."""

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

from . import _native

PathLike = Union[str, "os.PathLike[str]"]
Envelope = Union[str, Sequence[float]]
"""An envelope: ``"15x15x3"`` or ``(width_m, depth_m, height_m)``."""

CATEGORIES: Dict[int, str] = {c["id"]: c["name"] for c in json.loads(_native.categories_json())}
"""COCO category id -> name: 1..10 the object classes, 11 the door threshold."""
_CATEGORY_IDS = {name: i for i, name in CATEGORIES.items()}


@dataclass(frozen=True)
class Room:
    """A room: its id, type (from the room library) and floor rectangle in metres."""

    id: int
    type: str
    min: Tuple[float, float]
    max: Tuple[float, float]

    @property
    def area_m2(self) -> float:
        return (self.max[0] - self.min[0]) * (self.max[1] - self.min[1])


@dataclass(frozen=True)
class Door:
    """A doorway between two rooms (``None``: outside), its centre, size and wall normal."""

    id: int
    rooms: Tuple[Optional[int], Optional[int]]
    center: Tuple[float, float, float]
    width_m: float
    height_m: float


@dataclass(frozen=True)
class Threshold:
    """The low gold sill in a doorway: an obstacle the camera should see in time."""

    id: int
    door: int
    instance_id: int
    min: Tuple[float, float, float]
    max: Tuple[float, float, float]


@dataclass(frozen=True)
class SceneObject:
    """A placed object of one of the 10 classes, with its COCO category and instance id (the
    value of its pixels in ``Frame.instance_ids``)."""

    id: int
    class_name: str
    category_id: int
    instance_id: int
    room: Optional[int]
    asset: str
    min: Tuple[float, float, float]
    max: Tuple[float, float, float]
    yaw_deg: float


def _envelope_text(envelope: Optional[Envelope]) -> Optional[str]:
    if envelope is None or isinstance(envelope, str):
        return envelope
    w, d, h = (float(v) for v in envelope)
    return f"{w}x{d}x{h}"


def house_kwargs(
    envelope: Optional[Envelope] = None,
    min_room: Optional[float] = None,
    rooms: Optional[PathLike] = None,
    furniture: Optional[PathLike] = None,
) -> Dict[str, Any]:
    """The house options as the native calls take them."""
    return {
        "envelope": _envelope_text(envelope),
        "min_room": None if min_room is None else float(min_room),
        "rooms": None if rooms is None else os.fspath(rooms),
        "furniture": None if furniture is None else os.fspath(furniture),
    }


class Scene:
    """A generated house: its rooms, doors, thresholds and objects, its manifest, the agent's
    walk through it, and export to glTF/GLB, OBJ or USD."""

    def __init__(self, native: _native.Scene) -> None:
        self._native = native

    @property
    def seed(self) -> int:
        return self._native.seed

    @cached_property
    def manifest(self) -> Dict[str, Any]:
        """The manifest (what ``scene.json`` holds): rooms, walls, doors, windows, thresholds,
        objects, lights, and the record that rebuilds the house."""
        manifest: Dict[str, Any] = json.loads(self._native.manifest_json())
        return manifest

    @property
    def rooms(self) -> List[Room]:
        return [Room(r["id"], r["type"], tuple(r["min"]), tuple(r["max"])) for r in self.manifest["rooms"]]

    @property
    def doors(self) -> List[Door]:
        return [
            Door(d["id"], tuple(d["rooms"]), tuple(d["center"]), d["width_m"], d["height_m"])
            for d in self.manifest["doors"]
        ]

    @property
    def thresholds(self) -> List[Threshold]:
        return [
            Threshold(t["id"], t["door"], t["instance_id"], tuple(t["min"]), tuple(t["max"]))
            for t in self.manifest["thresholds"]
        ]

    @property
    def objects(self) -> List[SceneObject]:
        return [
            SceneObject(
                o["id"],
                o["class"],
                _CATEGORY_IDS[o["class"]],
                o["instance_id"],
                o["room"],
                o["asset"],
                tuple(o["min"]),
                tuple(o["max"]),
                o["yaw_deg"],
            )
            for o in self.manifest["objects"]
        ]

    def export(self, out: PathLike, format: str = "glb") -> List[Path]:
        """Writes the house into the folder ``out`` in ``format`` (``glb``, ``gltf``, ``obj``,
        ``usda`` or ``usdc``; USD needs usd-core in this Python) with ``scene.json`` and
        ``plan.png``, byte for byte as ``scene-gen --seed N --format FORMAT`` writes them.
        Returns the paths written."""
        return [Path(p) for p in self._native.export(os.fspath(out), format, sys.executable)]

    def walk(self, height_m: Optional[float] = None) -> Dict[str, Any]:
        """The agent's walk through every room (one pose per 0.25 m at 1 m/s): ``poses``, a list
        of dicts with ``x``, ``y``, ``z``, ``yaw_deg``, ``time_s`` (a valid ``poses=`` for
        :func:`scene_gen.render`), and ``crossings``, the door passages."""
        poses, crossings = self._native.walk(height_m)
        return {
            "poses": [dict(zip(("x", "y", "z", "yaw_deg", "time_s"), p)) for p in poses],
            "crossings": [dict(zip(("threshold_id", "pose_index", "time_s"), c)) for c in crossings],
        }

    def __repr__(self) -> str:
        return repr(self._native)


def generate(
    seed: int,
    envelope: Optional[Envelope] = None,
    min_room: Optional[float] = None,
    rooms: Optional[PathLike] = None,
    furniture: Optional[PathLike] = None,
) -> Scene:
    """The house of ``seed``: the same house ``scene-gen --seed SEED`` builds with the same
    options. ``envelope`` is ``"WxDxH"`` or ``(w, d, h)`` in metres (default 15 x 15 x 3),
    ``min_room`` the smallest room side in metres (default 5), ``rooms`` and ``furniture``
    library folders (default: the embedded libraries). Raises ``ValueError`` for options that
    do not fit or a library that does not load."""
    native = _native.generate(seed, **house_kwargs(envelope, min_room, rooms, furniture))
    return Scene(native)


__all__ = ["CATEGORIES", "Door", "Envelope", "Room", "Scene", "SceneObject", "Threshold", "generate"]
