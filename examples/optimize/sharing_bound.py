"""What sharing one camera centre per pose could save a GA run's rendering, at most.

    .venv/bin/python examples/optimize/sharing_bound.py RUN_DIR [crates/camera/src/sensor/catalog.toml]

RUN_DIR is an `scene-gen optimize` run directory (its candidates.csv). Every candidate of a run
looks from the same centre at each pose (height is not a gene of the default task), in the
pose's heading, tilted by its own pitch, so what the scene sends along a direction is the same
for all of them. A store of it per pose (a panorama) would be rendered once, at the finest
density any candidate needs in each direction, and read by all. For an oracle store (any local
density, perfect reuse) the pixels rendered per pose are the integral over the sphere of the
densest candidate's pixels per steradian; without sharing they are the candidates' own pixels.
The ratio bounds the render's saving; the sensor, ISP and ORB work on each candidate's own
pixels stays. Printed for the whole run sharing one store, and for each generation sharing its
own (a run evaluates generation after generation).

A pinhole pixel at angle a off the optical axis of a lens of focal length f with pixel pitch p
spans (p / f)^2 cos^3(a) steradians; the grid is 0.1 degree in yaw and elevation.
"""

import csv
import math
import sys
import tomllib

import numpy as np

STEP_RAD = math.radians(0.1)


def directions():
    """Unit directions (x right, y up, z ahead) of the grid's cells over the front hemisphere
    of yaw, and each cell's solid angle."""
    yaw = np.arange(-math.pi / 2, math.pi / 2, STEP_RAD) + STEP_RAD / 2
    elevation = np.arange(-math.pi / 2, math.pi / 2, STEP_RAD) + STEP_RAD / 2
    y, e = np.meshgrid(yaw, elevation)
    d = np.stack([np.cos(e) * np.sin(y), np.sin(e), np.cos(e) * np.cos(y)], -1)
    return d, np.cos(e) * STEP_RAD * STEP_RAD


def density_per_sr(candidate, sensor, d):
    """The candidate's pixels per steradian in each direction of `d` (0 outside its frame)."""
    w, h = sensor["resolution"]
    pitch_mm = sensor["pixel_pitch_um"] / 1000
    f_mm = float(candidate["focal_mm"])
    tilt = math.radians(float(candidate["pitch_deg"]))
    # Into the camera's frame: undo the tilt about the x axis.
    y = d[..., 1] * math.cos(tilt) - d[..., 2] * math.sin(tilt)
    z = d[..., 1] * math.sin(tilt) + d[..., 2] * math.cos(tilt)
    with np.errstate(divide="ignore", invalid="ignore"):
        u, v = f_mm * d[..., 0] / z, f_mm * y / z
        inside = (z > 0) & (np.abs(u) <= w * pitch_mm / 2) & (np.abs(v) <= h * pitch_mm / 2)
        return np.where(inside, (f_mm / pitch_mm) ** 2 / z**3, 0.0), w * h


def shared_pixels(candidates, sensors, d, cell_sr):
    """(the candidates' own pixels, the oracle store's pixels) of one pose."""
    densest = np.zeros_like(cell_sr)
    own = 0
    for c in candidates:
        density, pixels = density_per_sr(c, sensors[c["sensor"]], d)
        np.maximum(densest, density, out=densest)
        own += pixels
    return own, float((densest * cell_sr).sum())


def fail(message):
    """Bad input: the message on stderr, exit status 2, nothing printed on stdout."""
    print(f"sharing_bound: {message}", file=sys.stderr)
    sys.exit(2)


def read_inputs(run, catalog):
    """The catalog's sensors by model and the run's evaluated candidates, or `fail`."""
    try:
        with open(catalog, "rb") as f:
            sensors = {s["model"]: s for s in tomllib.load(f)["sensor"]}
        with open(f"{run}/candidates.csv", newline="") as f:
            # Elites are carried over, not evaluated again; rows keep their line numbers.
            evaluated = [(line, r) for line, r in enumerate(csv.DictReader(f), 2) if r.get("origin") != "elite"]
    except (OSError, tomllib.TOMLDecodeError, KeyError) as e:
        fail(f"{run}: cannot read the run's candidates.csv or the catalog {catalog}: {e}")
    if not evaluated:
        fail(f"{run}/candidates.csv: no evaluated candidate")
    for line, c in evaluated:
        if c.get("sensor") not in sensors:
            fail(f"{run}/candidates.csv:{line}: sensor {c.get('sensor')!r} is not in {catalog}")
        try:
            float(c["focal_mm"]), float(c["pitch_deg"])
        except (KeyError, TypeError, ValueError):
            fail(f"{run}/candidates.csv:{line}: focal_mm or pitch_deg missing or not a number")
    return sensors, [c for _, c in evaluated]


def main():
    if len(sys.argv) not in (2, 3):
        fail("usage: " + __doc__.strip().splitlines()[2].strip())
    run = sys.argv[1]
    catalog = sys.argv[2] if len(sys.argv) == 3 else "crates/camera/src/sensor/catalog.toml"
    sensors, evaluated = read_inputs(run, catalog)
    d, cell_sr = directions()
    mean_mp = sum(math.prod(sensors[c["sensor"]]["resolution"]) for c in evaluated) / len(evaluated) / 1e6
    print(f"{run}: {len(evaluated)} evaluations, mean sensor {mean_mp:.2f} MP")
    own, store = shared_pixels(evaluated, sensors, d, cell_sr)
    print(f"  one store for the run:      own {own / 1e6:7.1f} MP per pose, store {store / 1e6:6.1f} MP: x{own / store:.2f}")
    generations = {}
    for c in evaluated:
        generations.setdefault(c["generation"], []).append(c)
    own = store = 0
    for members in generations.values():
        o, s = shared_pixels(members, sensors, d, cell_sr)
        own, store = own + o, store + s
    print(f"  one store per generation:   own {own / 1e6:7.1f} MP per pose, store {store / 1e6:6.1f} MP: x{own / store:.2f}")


if __name__ == "__main__":
    main()
