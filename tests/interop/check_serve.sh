#!/usr/bin/env bash
# Plug-in protocol interop check: the Optuna example (examples/optuna/optimize_camera.py, Optuna
# pinned in requirements.txt) drives a real `scene-gen serve` for a few trials on a tiny budget;
# the best camera it prints must load in `scene-gen evaluate --camera` and score exactly what the
# server reported for it (same evaluator, deterministic). A wide, steep IMX174 (it sees door sills
# even at 64 px) is enqueued twice, so the best score is not 0 and the repeat must be cached.
set -euo pipefail
cd "$(dirname "$0")/../.."

bin=target/release/scene-gen
py=.venv/bin/python
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

budget=(--seeds 0 --frames 2 --max-width 64)
"$py" examples/optuna/optimize_camera.py --binary "$bin" --trials 4 --sampler-seed 1 "${budget[@]}" \
  --enqueue IMX174,2,-20 --enqueue imx174,2,-20 --out "$tmp/best.toml" --summary "$tmp/summary.json" >"$tmp/stdout"
echo "optuna driver: 4 trials through scene-gen serve, best camera:"
sed 's/^/  /' "$tmp/best.toml"
cmp -s "$tmp/stdout" "$tmp/best.toml" || { echo "FAIL: printed TOML differs from --out file" >&2; exit 1; }

"$bin" evaluate --camera "$tmp/best.toml" "${budget[@]}" --json >"$tmp/eval.json"

"$py" - "$tmp/summary.json" "$tmp/eval.json" <<'PY'
import json, sys
summary = json.load(open(sys.argv[1]))
ev = json.load(open(sys.argv[2]))
assert summary["protocol"] == "scene-gen/serve/2", summary["protocol"]
assert summary["trials"] == 4 and summary["completed"] == 4, summary
assert summary["cached"] >= 1, f"the repeated candidate must come from the server's cache: {summary}"
assert summary["best_fitness"]["mean"] > 0, f"the enqueued camera scores > 0 at this budget: {summary}"
best = summary["best_camera"]
for key in ("sensor", "focal_mm", "pitch_deg"):
    assert ev["camera"][key] == best[key], (key, ev["camera"][key], best[key])
for s in ("day", "night", "mean"):
    a, b = ev["fitness"][s], summary["best_fitness"][s]
    assert abs(a - b) < 1e-12, f"fitness {s}: evaluate {a} vs serve {b}"
print(f"scene-gen evaluate loads best.toml ({best['sensor']}, {best['focal_mm']} mm, {best['pitch_deg']} deg) "
      f"and reproduces the served fitness {ev['fitness']['mean']:.6f}")
PY
echo "check_serve: OK"
