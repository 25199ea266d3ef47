#!/usr/bin/env bash
# study_renders.sh SOURCE_DIR SIPROJECT SIMETRICS SIRAYS
#
# The studies' renders are make's render targets under its one staleness rule
# (ctest label e2e; seconds): make compare on a tiny scene of a temporary
# SCENEDIR, 8 x 8 pixels, factors 1 and 2, a reference at factor 3 and one
# POV-Ray antialiasing baseline (a render with options), run three times:
#   - the first run renders all four, and each render has its statistics
#     beside it (NAME.stats: POV-Ray's wall time, parse and trace times);
#   - a second run with the scene unchanged renders nothing and leaves the
#     renders' files as they were;
#   - after the scene is edited (its colour), the third run renders all
#     four again, and the reference's pixels are the new colour's and black.
set -euo pipefail
[ $# -eq 4 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT SIMETRICS SIRAYS" >&2; exit 64; }
src=$1 siproject=$2 simetrics=$3 sirays=$4
python=$src/.venv/bin/python
[ -x "$python" ] || { echo "FAIL: $python missing (run scripts/setup.sh)" >&2; exit 1; }
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-study-renders.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

mkdir "$tmp/scenes"
scene() {  # a checker of R G B and black squares (ambient 1, no light: exact colours)
  cat > "$tmp/scenes/tiny.pov" <<POV
#version 3.7;
global_settings { assumed_gamma 1.0 ambient_light rgb 1 }
camera { perspective location <0, 0, -1> look_at <0, 0, 0> right x up y angle 60 }
plane { z, 0 pigment { checker rgb <$1, $2, $3> rgb 0 scale 0.15 } finish { ambient 1 diffuse 0 } }
POV
}
mk() {
  make -C "$src" --no-print-directory SIPROJECT="$siproject" SIMETRICS="$simetrics" SIRAYS="$sirays" \
    OUT="$tmp/out" SCENEDIR="$tmp/scenes" COMPARE_SCENES=tiny COMPARE_RES=8 COMPARE_FACTORS="1 2" \
    COMPARE_REF_FACTOR=3 COMPARE_AA=am1-r1 COMPARE_REPEATS=1 COMPARE_BORDER=1 METHODS="box me-cubic" \
    QUICK=1 compare >"$1" 2>&1 || { cat "$1" >&2; fail "make compare on the tiny scene"; }
}
renders=("$tmp/out/compare-quick/render/tiny-8-f1.exr" "$tmp/out/compare-quick/render/tiny-8-f2.exr"
         "$tmp/out/compare-quick/render/tiny-8-f3.exr" "$tmp/out/compare-quick/pov-aa/am1-r1/render/tiny-8-f1.exr")
state() { stat -c '%n %i %Y %s' "${renders[@]}" "${renders[@]/%.exr/.stats}"; }
made() { grep -cE '^render ' "$1" || true; }

scene 0.25 0.5 0.75
mk "$tmp/log1"
[ "$(made "$tmp/log1")" -eq 4 ] || { cat "$tmp/log1" >&2; fail "the first run made $(made "$tmp/log1") renders, not 4"; }
for r in "${renders[@]}"; do
  [ -s "$r" ] || fail "no render $r"
  grep -Eq '^wall_s [0-9]+\.[0-9]+$' "${r%.exr}.stats" && grep -Eq '^parse_s [0-9.]+$' "${r%.exr}.stats" &&
    grep -Eq '^trace_s [0-9.]+$' "${r%.exr}.stats" || fail "${r%.exr}.stats lacks wall_s, parse_s or trace_s"
done
# Antialiasing off, POV-Ray traces one ray a pixel: 24 x 24 for the reference.
grep -qx 'pixels 576' "${renders[2]%.exr}.stats" || fail "the reference's statistics: $(cat "${renders[2]%.exr}.stats")"
echo "ok: the first run made 4 renders, each with its statistics"

before=$(state)
mk "$tmp/log2"
[ "$(made "$tmp/log2")" -eq 0 ] || fail "the scene unchanged, the second run rendered: $(grep -E '^render ' "$tmp/log2")"
grep -q '(0 renders, ' "$tmp/log2" || fail "the second run: $(tail -n 1 "$tmp/log2")"
[ "$(state)" = "$before" ] || fail "the second run touched the renders or their statistics"
echo "ok: the scene unchanged, nothing rendered again"

scene 1 0 0.5
mk "$tmp/log3"
[ "$(made "$tmp/log3")" -eq 4 ] || fail "the scene edited, the third run made $(made "$tmp/log3") renders, not 4"
grep -q '(4 renders, ' "$tmp/log3" || fail "the third run: $(tail -n 1 "$tmp/log3")"
"$python" - "${renders[2]}" <<'PY' || fail "the remade reference does not hold the edited scene's colour"
import sys
import numpy as np
import siproject
a = siproject.read_image(sys.argv[1])
assert a.shape == (24, 24, 3), a.shape
# half floats: 1, 0 and 0.5 are exact; both kinds of square are seen
colours = {tuple(p) for p in a.reshape(-1, 3).tolist()}
assert colours == {(1.0, 0.0, 0.5), (0.0, 0.0, 0.0)}, colours
PY
echo "ok: the scene edited, its renders made again with the new colour"
