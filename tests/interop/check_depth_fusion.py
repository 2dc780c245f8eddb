"""Back-projects a dataset's depth images with their intrinsics and poses and measures how far
the points land from the house's GLB surfaces (trimesh's closest-point query).

    python tests/interop/check_depth_fusion.py DATASET_DIR SCENE.glb [--shift-m D]

Each COCO image entry (annotations/instances_day.json) carries `K` (3x3, pixels, OpenCV:
pixel centres at integers) and `camera_to_world` (4x4, OpenCV axes: x right, y down, z
forward; world Z up, metres). A depth pixel (u, v) holding z millimetres is the point
camera_to_world @ [z (u - cx) / fx, z (v - cy) / fy, z, 1]. The GLB is Y up, so world
(x, y, z) is (x, z, -y) in its frame.

Passes when the median point-to-mesh distance of every image is below 1 cm and the median
angle between the frame's normals (`normal_file`, 16-bit RGB, n = v / 65535 * 2 - 1) and the
normals of the GLB triangles the points land on is below 5 degrees. The same points
back-projected with the OpenGL form of the pose (camera_to_world @ diag(1, -1, -1, 1), camera
looking down -z) must agree, which checks the stated conversion. `--shift-m D` moves every
camera by D metres along each world axis before back-projecting: the self-test that a wrong
pose fails.
"""

import json
import os
import sys

import cv2
import numpy as np
import trimesh

MAX_MEDIAN_M = 0.01
MAX_MEDIAN_ANGLE_DEG = 5.0
STRIDE = 3  # every third pixel in each direction: thousands of points per image


def sampled(depth_mm):
    """The pixels checked: every STRIDE-th pixel in each direction that has depth."""
    v, u = np.nonzero(depth_mm[::STRIDE, ::STRIDE])
    return v * STRIDE, u * STRIDE


def points_opencv(depth_mm, k, c2w):
    v, u = sampled(depth_mm)
    z = depth_mm[v, u].astype(np.float64) / 1000.0
    x = (u - k[0][2]) / k[0][0] * z
    y = (v - k[1][2]) / k[1][1] * z
    cam = np.stack([x, y, z, np.ones_like(z)])
    return (np.asarray(c2w) @ cam)[:3].T


def points_opengl(depth_mm, k, c2w):
    """The same points through the OpenGL convention: x right, y up, the camera looking down -z."""
    gl = np.asarray(c2w) @ np.diag([1.0, -1.0, -1.0, 1.0])
    v, u = sampled(depth_mm)
    z = depth_mm[v, u].astype(np.float64) / 1000.0
    cam = np.stack([(u - k[0][2]) / k[0][0] * z, -(v - k[1][2]) / k[1][1] * z, -z, np.ones_like(z)])
    return (gl @ cam)[:3].T


def main(argv):
    args = argv[1:]
    shift = 0.0
    if "--shift-m" in args:
        i = args.index("--shift-m")
        shift = float(args[i + 1])
        del args[i : i + 2]
    dataset, glb = args
    with open(os.path.join(dataset, "annotations", "instances_day.json"), encoding="utf-8") as f:
        images = json.load(f)["images"]
    if not images:
        print("FAIL no images in the dataset", file=sys.stderr)
        return 1
    mesh = trimesh.load(glb, force="mesh")
    failures = []
    for image in images:
        missing = [key for key in ("K", "camera_to_world", "depth_file", "normal_file") if key not in image]
        if missing:
            failures.append(f"{image['file_name']}: no {', '.join(missing)} in its COCO entry")
            continue
        depth = cv2.imread(os.path.join(dataset, image["depth_file"]), cv2.IMREAD_UNCHANGED)
        if depth is None or depth.dtype != np.uint16:
            failures.append(f"{image['depth_file']}: not a 16-bit PNG")
            continue
        c2w = np.asarray(image["camera_to_world"], dtype=np.float64)
        c2w[:3, 3] += shift
        world = points_opencv(depth, image["K"], c2w)
        other = points_opengl(depth, image["K"], c2w)
        if len(world) == 0:
            failures.append(f"{image['file_name']}: no depth")
            continue
        gap = np.abs(world - other).max()
        if gap > 1e-6:
            failures.append(f"{image['file_name']}: the OpenGL form of the pose puts points {gap} m elsewhere")
        gltf = np.stack([world[:, 0], world[:, 2], -world[:, 1]], axis=1)
        _, distance, triangle = trimesh.proximity.closest_point(mesh, gltf)
        median, p90 = np.median(distance), np.percentile(distance, 90)
        # The frame's normals at the same pixels, against the GLB triangles' (Y up to Z up).
        encoded = cv2.imread(os.path.join(dataset, image["normal_file"]), cv2.IMREAD_UNCHANGED)
        v, u = sampled(depth)
        ours = encoded[v, u][:, ::-1].astype(np.float64) / 65535.0 * 2.0 - 1.0  # OpenCV reads BGR
        face = mesh.face_normals[triangle]
        theirs = np.stack([face[:, 0], -face[:, 2], face[:, 1]], axis=1)
        cosine = np.clip(np.abs(np.sum(ours * theirs, axis=1)), 0.0, 1.0)
        angle = np.median(np.degrees(np.arccos(cosine)))
        print(f"  {image['file_name']}: {len(distance)} points, median {median * 1e3:.2f} mm, "
              f"90th percentile {p90 * 1e3:.2f} mm from the GLB's surfaces; normals {angle:.2f} deg apart")
        if angle > MAX_MEDIAN_ANGLE_DEG:
            failures.append(f"{image['file_name']}: median normal angle {angle:.1f} deg "
                            f"(at most {MAX_MEDIAN_ANGLE_DEG:.0f})")
        if median > MAX_MEDIAN_M:
            failures.append(f"{image['file_name']}: median point-to-mesh distance {median * 1e3:.1f} mm "
                            f"(at most {MAX_MEDIAN_M * 1e3:.0f} mm)")
    for message in failures:
        print(f"FAIL {message}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
