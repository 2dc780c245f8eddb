#!/usr/bin/env bash
# The test-chart loop (scene-gen target) against effects applied by an independent path
# (tests/interop/target_effects.py: cv2.GaussianBlur, a cv2.filter2D line kernel, a numpy cos^4
# gain): each case must name exactly the applied effects and shrink the gap by 80 % or more; a
# clean chart (another noise realisation and sensor instance) must name nothing and leave nothing
# unexplained; a tone curve (numpy), outside the loop's library, must be reported unexplained in
# the patch means.
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=target/release/scene-gen
test -x "$bin" || { echo "check_target: build $bin first" >&2; exit 1; }
py=.venv/bin/python
cam="IMX174,focal_mm=8"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
[ -n "${KEEP_TMP:-}" ] && trap - EXIT && echo "check_target: keeping $tmp"

"$bin" target chart --camera "$cam" --out "$tmp/chart.png" >/dev/null
"$bin" target chart --camera "$cam" --out "$tmp/clean.png" --frame-seed 2 --pattern-seed 2 >/dev/null

fail=0
run_case() {
  local name=$1 expect=$2 measured=$3
  "$bin" target gap "$measured" --camera "$cam" --out "$tmp/out_$name" --json >"$tmp/$name.json"
  "$py" - "$tmp/$name.json" "$name" "$expect" <<'PY' || fail=1
import json, sys
r = json.load(open(sys.argv[1]))
name, expect = sys.argv[2], sorted(e for e in sys.argv[3].split(",") if e)
named = sorted(r["named"])
unexplained = [u["family"] for u in r["unexplained"]]
gi, gf = r["gap_initial"], r["gap_final"]
if name == "gamma":
    ok = "patch_mean" in unexplained
else:
    ok = named == expect and (not expect or gf <= 0.2 * gi) and (name != "clean" or not unexplained)
print(f"check_target: {name:16s} named {named or 'nothing'} (expected {expect or 'nothing'}); "
      f"gap {gi:.2f} -> {gf:.2f}; unexplained {unexplained or 'nothing'} {'ok' if ok else 'FAIL'}", flush=True)
sys.exit(0 if ok else 1)
PY
}

run_case clean "" "$tmp/clean.png"
"$py" tests/interop/target_effects.py "$tmp/chart.png" "$tmp/chart.layout.json" "$tmp/lens.png" --lens 1.5 >/dev/null
run_case lens_blur lens_blur "$tmp/lens.png"
"$py" tests/interop/target_effects.py "$tmp/chart.png" "$tmp/chart.layout.json" "$tmp/motion.png" --motion 7 >/dev/null
run_case motion_blur motion_blur "$tmp/motion.png"
"$py" tests/interop/target_effects.py "$tmp/chart.png" "$tmp/chart.layout.json" "$tmp/falloff.png" --falloff 30 >/dev/null
run_case falloff illumination_falloff "$tmp/falloff.png"
"$py" tests/interop/target_effects.py "$tmp/chart.png" "$tmp/chart.layout.json" "$tmp/two.png" --lens 1.2 --falloff 30 >/dev/null
run_case lens+falloff lens_blur,illumination_falloff "$tmp/two.png"
"$py" tests/interop/target_effects.py "$tmp/chart.png" "$tmp/chart.layout.json" "$tmp/gamma.png" --gamma 0.8 >/dev/null
run_case gamma "" "$tmp/gamma.png"

[ "$fail" = 0 ] || { echo "check_target: FAILED" >&2; exit 1; }
echo "check_target: all cases passed"
