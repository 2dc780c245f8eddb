"""scene-gen from Python: seeded indoor houses, a physical camera simulator, camera evaluation
and detection datasets.

The heavy work runs in Rust (the ``scene_gen._native`` module); every long call releases the
GIL, and ``progress=`` takes a callable told ``(done, planned)`` as units of work finish.

    >>> import scene_gen as sg
    >>> scene = sg.generate(7)                               # the house `scene-gen --seed 7` makes
    >>> scene.export("out/house", format="glb")              # scene.glb, scene.json, plan.png
    >>> frames = sg.render(scene, "IMX172,focal_mm=4", frames=3, lighting="both", max_width=320)
    >>> f = frames[0]
    >>> f.image.shape, f.depth.dtype, f.K, f.camera_to_world  # arrays, intrinsics, OpenCV pose
    >>> sg.evaluate("IMX172,focal_mm=4", seeds=range(2))["fitness"]
    >>> sg.write_dataset("data/", "IMX172,focal_mm=4", seeds="0..4", frames=5, max_width=320)
    >>> sg.optimize("runs/ga", config="optimize.toml")      # = scene-gen optimize

``scene_gen.ray`` runs dataset seeds and optimizer generations as Ray tasks.

Conventions: world coordinates in metres, Z up (as the manifest). ``camera_to_world`` maps
OpenCV camera axes (x right, y down, z forward) to the world; ``Frame.camera_to_world_opengl``
gives the OpenGL / Blender form (y up, z backward). ``K`` is the OpenCV intrinsic matrix with
pixel centres at integer coordinates.
"""

from __future__ import annotations

from ._native import __version__
from .camera import Camera, camera, sensors
from .design import Dataset, evaluate, optimize, write_dataset
from .frames import Frame, render
from .house import CATEGORIES, Door, Room, Scene, SceneObject, Threshold, generate

__all__ = [
    "CATEGORIES",
    "Camera",
    "Dataset",
    "Door",
    "Frame",
    "Room",
    "Scene",
    "SceneObject",
    "Threshold",
    "__version__",
    "camera",
    "evaluate",
    "generate",
    "optimize",
    "render",
    "sensors",
    "write_dataset",
]
