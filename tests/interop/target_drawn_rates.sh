#!/usr/bin/env bash
# How often `scene-gen target gap` reaches each verdict on charts drawn by another tool
# (tests/interop/draw_chart.py: OpenCV, scikit-image and numpy) over noise seeds FIRST..LAST:
# for each case, the count of each (named, tentative, unexplained) outcome. The figures of
# docs/BENCHMARKS.md ("target gap") come from it; check_target.sh gates a few seeds of each.
#
#   bash tests/interop/target_drawn_rates.sh FIRST LAST [CASE ...]
#
# CASE is one of: clean lens motion falloff lens+falloff gamma sharpen (default: all).
set -euo pipefail
cd "$(dirname "$0")/../.."
[ $# -ge 2 ] || { echo "usage: $0 FIRST LAST [CASE ...]" >&2; exit 2; }
first=$1 last=$2
shift 2
bin=target/release/scene-gen
test -x "$bin" || { echo "target_drawn_rates: build $bin first" >&2; exit 1; }
py=.venv/bin/python
cam="IMX174,focal_mm=8"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$bin" target chart --camera "$cam" --out "$tmp/chart.png" >/dev/null

declare -A args=(
  [clean]="" [lens]="--lens 1.5" [motion]="--motion 7" [falloff]="--falloff 20"
  [lens+falloff]="--lens 1.2 --falloff 20" [gamma]="--gamma 0.8" [sharpen]="--sharpen 0.5"
)
cases=("$@")
[ ${#cases[@]} -gt 0 ] || cases=(clean lens motion falloff lens+falloff gamma sharpen)
for c in "${cases[@]}"; do
  [ -n "${args[$c]+set}" ] || { echo "target_drawn_rates: unknown case $c" >&2; exit 2; }
  for seed in $(seq "$first" "$last"); do
    # shellcheck disable=SC2086
    "$py" tests/interop/draw_chart.py "$tmp/chart.layout.json" "$tmp/m.png" --seed "$seed" ${args[$c]}
    "$bin" target gap "$tmp/m.png" --camera "$cam" --out "$tmp/out" --json --quiet |
      "$py" -c 'import json, sys; r = json.load(sys.stdin); print(sorted(r["named"]), sorted(r["tentative"]), sorted(u["family"] for u in r["unexplained"]))'
  done | sort | uniq -c | sed "s/^/$c: /"
done
