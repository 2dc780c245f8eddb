"""Frames from Python: the command line's render, as arrays, with intrinsics and pose."""

import json
import threading
import time

import cv2
import numpy as np
import pytest

import scene_gen as sg

CAMERA = "IMX174,focal_mm=3"
RENDER = dict(lighting="both", quality="preview", max_width=160)


@pytest.fixture(scope="module")
def scene():
    return sg.generate(5)


def png(path):
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert image is not None, path
    return image


def test_render_matches_the_command_line(cli, tmp_path, scene):
    cli("render", "--seed", 5, "--camera", CAMERA, "--frames", 3, "--lighting", "both",
        "--quality", "preview", "--max-width", 160, "--raw", "--out", tmp_path)
    frames = sg.render(scene, CAMERA, frames=3, **RENDER)
    assert [(f.index, f.lighting) for f in frames] == [(k, l) for k in range(3) for l in ("day", "night")]
    for f in frames:
        stem = tmp_path / f"frame_{f.index:04d}"
        sidecar = json.loads((tmp_path / f"frame_{f.index:04d}_{f.lighting}.json").read_text())
        assert np.array_equal(f.raw, png(f"{stem}_{f.lighting}_raw.png"))
        # OpenCV reads colour as BGR.
        assert np.array_equal(f.image, cv2.cvtColor(png(f"{stem}_{f.lighting}.png"), cv2.COLOR_BGR2RGB))
        assert f.bits == sidecar["bits"] and f.gain_db == sidecar["gain_db"]
        assert f.cfa_pattern == sidecar["cfa_pattern"] == "RGGB"
        np.testing.assert_array_equal(f.K, np.array(sidecar["K"]))
        np.testing.assert_array_equal(f.camera_to_world, np.array(sidecar["camera_to_world"]))
        assert np.array_equal(f.instance_ids, png(f"{stem}_instances.png").astype(np.uint32))
        depth_mm = png(f"{stem}_depth.png")
        mm = f.depth.astype(np.float64) * 1000  # the PNG's millimetres, rounded half away from 0
        near = np.isfinite(mm) & (mm < 65535)
        assert np.array_equal(np.floor(mm[near] + 0.5).astype(np.uint16), depth_mm[near])
        assert (depth_mm[~np.isfinite(f.depth)] == 0).all()


def test_evaluator_quality_matches_the_command_line(cli, tmp_path, scene):
    cli("render", "--seed", 5, "--camera", CAMERA, "--frames", 1, "--lighting", "day",
        "--quality", "evaluator", "--max-width", 96, "--out", tmp_path)
    (f,) = sg.render(scene, CAMERA, frames=1, lighting="day", quality="evaluator", max_width=96)
    assert np.array_equal(f.image, cv2.cvtColor(png(tmp_path / "frame_0000_day.png"), cv2.COLOR_BGR2RGB))
    (p,) = sg.render(scene, CAMERA, frames=1, lighting="day", quality="preview", max_width=96)
    assert not np.array_equal(f.image, p.image), "the evaluator's anchors shade another image than preview"
    np.testing.assert_array_equal(f.instance_ids, p.instance_ids)

def test_frame_buffers_agree(scene):
    (f,) = sg.render(scene, CAMERA, frames=1, lighting="day", quality="preview", max_width=96)
    h, w = f.depth.shape
    assert f.image.shape == (h, w, 3)
    assert f.raw.shape == f.instance_ids.shape == f.class_ids.shape == (h, w)
    assert f.image.dtype == np.uint8 and f.raw.dtype == np.uint16 and f.raw.max() < 2**f.bits
    hit = np.isfinite(f.depth)
    assert hit.any()
    assert np.allclose(np.linalg.norm(f.normals[hit], axis=-1), 1, atol=1e-3)
    assert (f.normals[~hit] == 0).all()
    assert ((f.instance_ids > 0) == (f.class_ids > 0)).all()
    rotation = f.camera_to_world[:3, :3]
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-6)
    # The OpenGL form looks down its -z axis: the OpenCV form's +z.
    np.testing.assert_allclose(f.camera_to_world_opengl[:3, 2], -rotation[:, 2])
    points = f.points()
    assert points.shape == (hit.sum(), 3)
    # Every surface seen lies inside the house's envelope (Z up, floor at 0, 3 m ceiling).
    assert points[:, 2].min() > -0.01 and points[:, 2].max() < 3.01


def test_given_poses_render_like_the_walk(scene):
    walk = scene.walk()
    walked = sg.render(scene, CAMERA, frames=2, **RENDER)
    given = sg.render(scene, CAMERA, poses=walk["poses"][:2], **RENDER)
    as_array = sg.render(
        scene, CAMERA, poses=np.array([[p["x"], p["y"], p["z"], p["yaw_deg"]] for p in walk["poses"][:2]]), **RENDER
    )
    for a, b, c in zip(walked, given, as_array):
        assert np.array_equal(a.raw, b.raw) and np.array_equal(a.depth, b.depth)
        np.testing.assert_array_equal(a.camera_to_world, c.camera_to_world)


def test_pose_overrides_height_and_pitch(scene):
    p = scene.walk()["poses"][0]
    (low,) = sg.render(scene, CAMERA, poses=[{**p, "z": 0.3, "pitch_deg": -20}], lighting="day", quality="preview", max_width=64)
    assert abs(low.camera_to_world[2, 3] - 0.3) < 1e-6 and low.pitch_deg == -20


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"poses": [(1.0, float("nan"), 0.0)]}, r"poses\[0\]: y"),
        ({"poses": [(1.0, 2.0)]}, r"poses\[0\]"),
        ({"poses": [{"x": 1.0, "yaw_deg": 0}]}, "missing y"),
        ({"poses": []}, "no poses"),
        ({"lighting": "dusk"}, "lighting"),
        ({"quality": "ultra"}, "quality"),
        ({"frames": 0}, "frames"),
        ({"max_width": 0}, "max_width"),
    ],
)
def test_bad_render_input_raises_value_error(scene, kwargs, words):
    with pytest.raises(ValueError, match=words):
        sg.render(scene, CAMERA, **kwargs)


def test_a_camera_at_the_ceiling_raises_value_error(scene):
    with pytest.raises(ValueError, match="height_m"):
        sg.render(scene, "IMX174,focal_mm=3,height_m=3", frames=1, **RENDER)
    with pytest.raises(ValueError, match="ceiling"):
        scene.walk(height_m=3.5)


def test_bad_cameras_raise_value_error():
    with pytest.raises(ValueError, match="NOPE"):
        sg.camera("NOPE,focal_mm=3")
    with pytest.raises(ValueError):
        sg.camera({"sensor": "IMX174", "focal_mm": -1})
    assert sg.camera({"sensor": "IMX174", "focal_mm": 3.0}).sensor == "IMX174"


def test_poses_file(scene, tmp_path):
    path = tmp_path / "path.csv"
    path.write_text("x,y,yaw_deg\n2.0,2.0,45\n2.5,2.0,45\n")
    frames = sg.render(scene, CAMERA, poses=path, lighting="day", quality="preview", max_width=64)
    assert [f.index for f in frames] == [0, 1]
    path.write_text("x,y,yaw_deg\n2.0,oops,45\n")
    with pytest.raises(ValueError, match="line 2"):
        sg.render(scene, CAMERA, poses=path)


def test_progress_reports_every_frame(scene):
    calls = []
    sg.render(scene, CAMERA, frames=3, lighting="day", quality="preview", max_width=64,
              progress=lambda done, planned: calls.append((done, planned)))
    assert calls == [(1, 3), (2, 3), (3, 3)]


def test_an_exception_in_progress_stops_the_render(scene):
    calls = []

    def stop(done, planned):
        calls.append(done)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sg.render(scene, CAMERA, frames=5, lighting="day", quality="preview", max_width=64, progress=stop)
    assert calls == [1]


def test_the_gil_is_released_while_rendering(scene):
    """Python threads run while Rust renders: a counter in this thread keeps climbing."""
    done = threading.Event()

    def work():
        sg.render(scene, CAMERA, frames=4, lighting="both", quality="standard", max_width=240)
        done.set()

    thread = threading.Thread(target=work)
    count = 0
    start = time.perf_counter()
    thread.start()
    while not done.is_set():
        count += 1
    thread.join()
    elapsed = time.perf_counter() - start
    # A held GIL would let this loop run only in the interpreter's switch slots around the
    # render's few Python calls; released, it spins the whole time (millions per second).
    assert elapsed > 0.05 and count / elapsed > 100_000, (count, elapsed)
