"""Frames: what a camera sees from a pose, as NumPy arrays with its intrinsics and pose."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Callable, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from .camera import CameraLike, camera as _camera
from .house import PathLike, Scene

Progress = Callable[[int, int], Any]
"""A progress callback, called as ``progress(done, planned)`` after each unit of work."""

PoseLike = Union[Mapping[str, float], Sequence[float]]
"""A pose: a mapping with ``x``, ``y``, ``yaw_deg`` and optionally ``z``, ``pitch_deg``,
``time_s``, or a sequence ``(x, y, yaw_deg)`` / ``(x, y, z, yaw_deg)`` /
``(x, y, z, yaw_deg, pitch_deg)``."""

# OpenCV camera axes (x right, y down, z forward) to OpenGL ones (x right, y up, z backward).
_OPENCV_TO_OPENGL = np.diag([1.0, -1.0, -1.0, 1.0])


@dataclass
class Frame:
    """One lighting of one pose.

    ``image`` is the camera's 8-bit image: sRGB ``(H, W, 3)`` for a colour sensor (its raw
    Bayer mosaic through the ISP: black level, white balance, demosaicing, colour matrix, sRGB
    curve), grey ``(H, W)`` for a monochrome one. ``raw`` is the sensor's digital numbers at
    its ADC depth (``bits``), ``uint16``: the Bayer mosaic ``(H, W)`` whose layout is
    ``cfa_pattern`` (``"RGGB"``...), a grey ``(H, W)`` image (``cfa_pattern`` is ``None``), or
    ``(H, W, 3)`` on the affine noise path. ``depth`` is z-depth in metres
    (``inf`` where nothing is hit), ``instance_ids`` the manifest's instance ids (0: none),
    ``class_ids`` the COCO categories (0: none, 1..10 objects, 11 thresholds), ``normals`` unit
    world normals facing the camera (0 where nothing is hit). The geometry arrays are shared by
    the day and night frames of a pose.
    """

    index: int
    lighting: str
    image: np.ndarray
    raw: np.ndarray
    bits: int
    cfa_pattern: Optional[str]
    depth: np.ndarray
    instance_ids: np.ndarray
    class_ids: np.ndarray
    normals: np.ndarray
    K: np.ndarray
    camera_to_world: np.ndarray
    position: Tuple[float, float, float]
    yaw_deg: float
    pitch_deg: float
    time_s: float
    exposure_s: float
    gain_db: float
    plane_lux: float
    light_scale: float

    @property
    def camera_to_world_opengl(self) -> np.ndarray:
        """``camera_to_world`` for OpenGL / Blender camera axes (y up, z backward)."""
        return self.camera_to_world @ _OPENCV_TO_OPENGL

    def points(self) -> np.ndarray:
        """The depth back-projected through ``K`` and ``camera_to_world``: world points (N, 3)
        of every pixel that hit something."""
        h, w = self.depth.shape
        v, u = np.mgrid[0:h, 0:w]
        hit = np.isfinite(self.depth)
        z = self.depth[hit].astype(np.float64)
        fx, fy, cx, cy = self.K[0, 0], self.K[1, 1], self.K[0, 2], self.K[1, 2]
        cam = np.stack([(u[hit] - cx) / fx * z, (v[hit] - cy) / fy * z, z, np.ones_like(z)])
        world: np.ndarray = (self.camera_to_world @ cam)[:3].T
        return world


def _array(buffer: bytearray, dtype: str, shape: Tuple[int, ...]) -> np.ndarray:
    return np.frombuffer(buffer, dtype=dtype).reshape(shape)


def _frames(record: Dict[str, Any]) -> List[Frame]:
    h, w = record["height"], record["width"]
    geometry = {
        "depth": _array(record["depth"], "<f4", (h, w)),
        "instance_ids": _array(record["instance_ids"], "<u4", (h, w)),
        "class_ids": _array(record["class_ids"], "<u2", (h, w)),
        "normals": _array(record["normals"], "<f4", (h, w, 3)),
        "K": np.array(record["K"], dtype=np.float64),
        "camera_to_world": np.array(record["camera_to_world"], dtype=np.float64),
    }
    frames = []
    for shot in record["shots"]:
        channels = shot["channels"]
        raw_shape = (h, w) if channels == 1 else (h, w, channels)
        frames.append(
            Frame(
                index=record["index"],
                lighting=shot["lighting"],
                image=_array(shot["image"], "u1", (h, w) if shot["image_channels"] == 1 else (h, w, 3)),
                raw=_array(shot["raw"], "<u2", raw_shape),
                bits=shot["bits"],
                cfa_pattern=shot["cfa_pattern"],
                position=tuple(record["position"]),
                yaw_deg=record["yaw_deg"],
                pitch_deg=record["pitch_deg"],
                time_s=record["time_s"],
                exposure_s=shot["exposure_s"],
                gain_db=shot["gain_db"],
                plane_lux=shot["plane_lux"],
                light_scale=shot["light_scale"],
                **geometry,
            )
        )
    return frames


def _pose_tuple(i: int, pose: PoseLike) -> Tuple[float, float, Optional[float], float, Optional[float], Optional[float]]:
    if isinstance(pose, Mapping):
        missing = [k for k in ("x", "y", "yaw_deg") if k not in pose]
        if missing:
            raise ValueError(f"poses[{i}]: missing {', '.join(missing)}")
        z, pitch, time = (None if pose.get(k) is None else float(pose[k]) for k in ("z", "pitch_deg", "time_s"))
        return (float(pose["x"]), float(pose["y"]), z, float(pose["yaw_deg"]), pitch, time)
    values = [float(v) for v in pose]
    if len(values) == 3:
        x, y, yaw = values
        return (x, y, None, yaw, None, None)
    if len(values) in (4, 5):
        x, y, z, yaw = values[:4]
        return (x, y, z, yaw, values[4] if len(values) == 5 else None, None)
    raise ValueError(f"poses[{i}]: expected (x, y, yaw_deg), (x, y, z, yaw_deg) or (x, y, z, yaw_deg, pitch_deg)")


def render(
    scene: Scene,
    camera: CameraLike,
    poses: Union[None, PathLike, Iterable[PoseLike], np.ndarray] = None,
    frames: int = 1,
    lighting: str = "day",
    quality: str = "standard",
    max_width: Optional[int] = None,
    progress: Optional[Progress] = None,
) -> List[Frame]:
    """Renders ``scene`` through ``camera``: at the first ``frames`` poses of the agent's walk,
    or at ``poses`` (a list of poses, an (N, 3..5) array, or a JSON / CSV path file as
    ``scene-gen render --poses`` reads). ``lighting`` is ``day`` (20 lux on the 0.75 m plane),
    ``night`` (2 lux) or ``both``; ``quality`` ``evaluator`` (the evaluator's render, the
    fastest), ``preview``, ``standard`` or ``high``; ``max_width`` bins the sensor down
    (keeping the field of view). Returns one :class:`Frame` per pose and lighting, in pose
    order (day before night). The frames match ``scene-gen render``'s files for the same
    house, camera and poses."""
    cam = _camera(camera)
    pose_list = None
    pose_file = None
    if isinstance(poses, (str, os.PathLike)):
        pose_file = os.fspath(poses)
    elif poses is not None:
        rows = poses.tolist() if isinstance(poses, np.ndarray) else poses
        pose_list = [_pose_tuple(i, p) for i, p in enumerate(rows)]
    records = _native.render(
        scene._native,
        cam,
        poses=pose_list,
        poses_file=pose_file,
        frames=frames,
        lighting=lighting,
        quality=quality,
        max_width=max_width,
        progress=progress,
    )
    return [frame for record in records for frame in _frames(record)]


__all__ = ["Frame", "PoseLike", "Progress", "render"]
