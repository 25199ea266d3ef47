#!/usr/bin/env bash
# stability_quick.sh SOURCE_DIR BUILD_DIR
#
# End-to-end test of the stability study (ctest label e2e): runs
# scripts/stability.py --quick into a temporary folder and checks that every
# file the page names exists, that every method has finite numbers, that each
# measured noise gain lies within 4 standard deviations of the discrete
# operator's exact gain and that gain within 7 % of the continuous theory
# (the tent at factor 4 is off by 6.2 %), and that on the
# HDR scene clamping at zero leaves no negative pixel while the plain
# min-error cubic has some.
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: ${0##*/} SOURCE_DIR BUILD_DIR" >&2; exit 64; }
src=$1 build=$2
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-stability.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
"$src/.venv/bin/python" "$src/scripts/stability.py" --quick --build "$build" --out "$tmp/report/stability"
"$src/.venv/bin/python" - "$tmp/report/stability" <<'PY'
import json, math, os, re, sys
d = sys.argv[1]
page = open(os.path.join(d, "index.html")).read()
names = set(re.findall(r'(?:src|href)="([^"#]+)"', page))
missing = [n for n in names if not os.path.exists(os.path.join(d, n))]
assert not missing, f"the page names missing files: {missing}"
r = json.load(open(os.path.join(d, "stability.json")))
def finite(x):
    if isinstance(x, dict): return all(finite(v) for v in x.values())
    if isinstance(x, list): return all(finite(v) for v in x)
    return not isinstance(x, float) or math.isfinite(x)
assert finite(r), "a number is not finite"
methods = {"box", "conv-tent", "mitchell", "me-tent", "me-cubic", "me-tent-2x2", "me-cubic-2x2"}
assert {e["method"] for e in r["edges"]} == methods, "edges: a method is missing"
for n in r["synthetic"]["noise"]["methods"]:
    # the seeded measurement scatters about the discrete operator's exact gain
    # by its standard deviation (from the outputs' correlation)
    assert abs(n["gain"] - n["discrete"]) < 4 * n["measurement_sd"], f"noise gain off the exact gain: {n}"
    assert abs(n["discrete"] / n["theory"] - 1) < 0.07, f"exact gain far from the continuous theory: {n}"
hdr = {(h["method"], h["remedy"]): h for h in r["hdr"]}
assert hdr[("me-cubic", "none")]["negative_pixels"] > 0, "plain min-error cubic shows no negatives"
assert hdr[("me-cubic", "clamp zero")]["negative_pixels"] == 0, "clamp zero left negatives"
print(f"ok: {len(names)} files named, all present; {len(r['hdr'])} HDR rows")
PY
