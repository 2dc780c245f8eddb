#!/usr/bin/env python3
"""Designs a camera with Optuna by driving `scene-gen serve` (the plug-in protocol).

Starts one `scene-gen serve` process, asks it for the design space (`{"op": "describe"}`:
sensor names ordered by area, the focal-length and pitch ranges), lets a seeded TPE sampler
propose (sensor, focal_mm, pitch_deg) candidates, sends each as one JSON line and reads its
scores back, and prints the best camera as TOML that `scene-gen evaluate --camera` accepts.

    python examples/optuna/optimize_camera.py --trials 30 --seeds 0..2 --out best.toml

Nothing here is specific to Optuna except `objective`: any optimizer that can call a function
can use `SceneGen.evaluate`.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys

import optuna

PROTOCOL = "scene-gen/serve/2"


class ServeError(RuntimeError):
    """The server answered a request with an error response."""

    def __init__(self, response: dict):
        err = response.get("error", {})
        self.kind = err.get("kind", "?")
        super().__init__(f"{self.kind}: {err.get('message', '?')} (request line {err.get('line', '?')})")


class SceneGen:
    """One `scene-gen serve` process; requests are answered one at a time, in order."""

    def __init__(self, binary: str, seeds: str, frames: int, max_width: int):
        cmd = [binary, "serve", "--seeds", seeds, "--frames", str(frames), "--max-width", str(max_width)]
        # stderr is inherited: the server's own messages reach the user unchanged.
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1)
        self.next_id = 0

    def request(self, body: dict) -> dict:
        self.next_id += 1
        body = {"id": self.next_id, **body}
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(json.dumps(body) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"scene-gen serve ended early (exit status {self.proc.wait()})")
        response = json.loads(line)
        if response.get("id") != body["id"]:
            raise RuntimeError(f"response to request {response.get('id')!r}, expected {body['id']}")
        if not response.get("ok"):
            raise ServeError(response)
        return response

    def describe(self) -> dict:
        d = self.request({"op": "describe"})
        if d.get("protocol") != PROTOCOL:
            raise RuntimeError(f"server speaks {d.get('protocol')!r}, this driver {PROTOCOL!r}")
        return d

    def evaluate(self, camera: dict) -> dict:
        return self.request({"camera": camera})

    def close(self) -> int:
        assert self.proc.stdin is not None
        self.proc.stdin.close()
        return self.proc.wait()


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        if isinstance(v, float) and not math.isfinite(v):
            raise ValueError(f"{v} has no TOML form here")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string for the ASCII names and enums of a spec
    raise TypeError(f"unexpected value {v!r}")


def camera_toml(camera: dict, comment: list[str]) -> str:
    lines = [f"# {c}" for c in comment]
    lines += [f"{k} = {toml_value(v)}" for k, v in camera.items() if v is not None]
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--binary", default="scene-gen", help="path of the scene-gen binary")
    ap.add_argument("--trials", type=int, default=30)
    ap.add_argument("--seeds", default="0..1", help="house seeds: A..B, A..=B or one seed")
    ap.add_argument("--frames", type=int, default=25, help="anchor frames per house")
    ap.add_argument("--max-width", type=int, default=320, help="binned image width, px")
    ap.add_argument("--sampler-seed", type=int, default=0, help="seed of the TPE sampler")
    ap.add_argument(
        "--enqueue",
        action="append",
        default=[],
        metavar="SENSOR,FOCAL_MM,PITCH_DEG",
        help="evaluate this camera first (a known design to start from); repeatable",
    )
    ap.add_argument("--out", help="also write the best camera TOML here")
    ap.add_argument("--summary", help="write a JSON summary (best fitness, trials) here")
    args = ap.parse_args()
    if args.trials < 1:
        ap.error("--trials must be at least 1")
    starts = []
    for text in args.enqueue:
        parts = text.split(",")
        try:
            starts.append({"sensor": parts[0], "focal_mm": float(parts[1]), "pitch_deg": float(parts[2])})
        except (IndexError, ValueError):
            ap.error(f"--enqueue {text!r}: expected SENSOR,FOCAL_MM,PITCH_DEG, e.g. IMX174,4,-10")

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    server = SceneGen(args.binary, args.seeds, args.frames, args.max_width)
    try:
        d = server.describe()
        sensors, genes = d["sensors"], d["genes"]
        focal, pitch = genes["focal_mm"], genes["pitch_deg"]

        def objective(trial: optuna.Trial) -> float:
            camera = {
                "sensor": trial.suggest_categorical("sensor", sensors),
                "focal_mm": trial.suggest_float("focal_mm", focal["min"], focal["max"]),
                "pitch_deg": trial.suggest_float("pitch_deg", pitch["min"], pitch["max"]),
            }
            r = server.evaluate(camera)
            trial.set_user_attr("camera", r["camera"])
            trial.set_user_attr("fitness", r["fitness"])
            trial.set_user_attr("cached", r["cached"])
            print(
                f"trial {trial.number}: {camera['sensor']} {camera['focal_mm']:.2f} mm {camera['pitch_deg']:+.1f} deg"
                f" -> fitness {r['fitness']['mean']:.4f} ({r['seconds']:.2f} s{', cached' if r['cached'] else ''})",
                file=sys.stderr,
            )
            return r["fitness"]["mean"]

        study = optuna.create_study(direction="maximize", sampler=optuna.samplers.TPESampler(seed=args.sampler_seed))
        for start in starts:
            # Sensor names are matched case-insensitively by the server; Optuna needs the exact choice.
            match = [s for s in sensors if s.lower() == start["sensor"].lower()]
            if not match:
                raise SystemExit(f"--enqueue: unknown sensor {start['sensor']!r}")
            study.enqueue_trial({**start, "sensor": match[0]})
        # A candidate the server refuses (ServeError) fails its trial; the study goes on.
        study.optimize(objective, n_trials=args.trials, catch=(ServeError,))
    finally:
        status = server.close()
    if status != 0:
        print(f"scene-gen serve exited with status {status}", file=sys.stderr)
        return 1

    done = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    if not done:
        print("no trial completed", file=sys.stderr)
        return 1
    best = study.best_trial
    f = best.user_attrs["fitness"]
    text = camera_toml(
        best.user_attrs["camera"],
        [
            f"best of {len(study.trials)} Optuna TPE trials (sampler seed {args.sampler_seed}), trial {best.number}",
            f"fitness mean {f['mean']:.6f} (day {f['day']:.6f}, night {f['night']:.6f})",
            f"scene-gen evaluate --camera FILE --seeds {args.seeds} --frames {args.frames} --max-width {args.max_width}",
        ],
    )
    print(text, end="")
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write(text)
    if args.summary:
        summary = {
            "protocol": PROTOCOL,
            "trials": len(study.trials),
            "completed": len(done),
            "cached": sum(1 for t in done if t.user_attrs.get("cached")),
            "best_trial": best.number,
            "best_fitness": f,
            "best_camera": best.user_attrs["camera"],
        }
        with open(args.summary, "w", encoding="utf-8") as fh:
            json.dump(summary, fh, indent=2)
            fh.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
