"""Cameras: a sensor from the catalog, a lens and a mounting."""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Mapping, Union

from ._native import Camera, catalog_json

CameraLike = Union[Camera, str, "os.PathLike[str]", Mapping[str, Any]]
"""A camera as the functions take it: a :class:`Camera`, ``"SENSOR[,key=value...]"`` (as the
command line's ``--camera``), the path of a camera TOML file, or a mapping of the TOML file's
fields (``{"sensor": "IMX172", "focal_mm": 4.0}``)."""


def camera(spec: CameraLike) -> Camera:
    """The :class:`Camera` of ``spec`` (see :data:`CameraLike`); raises ``ValueError`` for a spec
    that does not parse or a sensor not in the catalog."""
    if isinstance(spec, Camera):
        return spec
    if isinstance(spec, Mapping):
        return Camera.from_json(json.dumps(dict(spec)))
    if isinstance(spec, (str, os.PathLike)):
        return Camera(os.fspath(spec))
    raise TypeError(f"camera: expected a Camera, a str, a path or a mapping, got {type(spec).__name__}")


def sensors() -> List[Dict[str, Any]]:
    """The sensor catalog: one dict per sensor (maker, model, resolution, pixel pitch, ADC bits,
    quantum efficiency, full well, read noise, dark current, and where each figure comes from)."""
    catalog: List[Dict[str, Any]] = json.loads(catalog_json())
    return catalog


__all__ = ["Camera", "CameraLike", "camera", "sensors"]
