#!/usr/bin/env bash
# tiles.sh SOURCE_DIR SIPROJECT SIMETRICS
#
# End-to-end test of `make TILES=k` (ctest label e2e): the checker scene at
# 32 x 32, factor 4, rendered once whole and once as 3 row bands (separate
# POV-Ray processes, run in parallel by make -j3), projected by two methods:
# the images from the bands must equal the single render's, bit for bit.
# Each band renders with one POV-Ray thread unless POV_THREADS says (one
# thread gives the same pixels on every run), and a bad POV_THREADS stops
# make before anything is made.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT SIMETRICS" >&2; exit 64; }
src=$1 siproject=$2 simetrics=$3
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-tiles.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
methods="me-cubic-2x2 conv-tent"
mk() {
  make -C "$src" --no-print-directory SIPROJECT="$siproject" SIMETRICS="$simetrics" \
    SCENE=checker RES=32 FACTOR=4 METHODS="$methods" "$@" scene >"$tmp/log" 2>&1 ||
    { cat "$tmp/log" >&2; echo "FAIL: make $*" >&2; exit 1; }
}
mk OUT="$tmp/whole"
mk -j3 OUT="$tmp/bands" TILES=3
bands=$(ls "$tmp/bands/render/"*band*of3.exr | wc -l)
[ "$bands" -eq 3 ] || { echo "FAIL: expected 3 band files, found $bands" >&2; exit 1; }
dry() { make -n -C "$src" --no-print-directory SIPROJECT="$siproject" SIMETRICS="$simetrics" \
  SCENE=checker RES=32 FACTOR=4 METHODS=box OUT="$tmp/dry" "$@" scene 2>&1; }
n=$(dry TILES=3 | grep -c 'render_band\.sh .* +WT1 *$' || true)
[ "$n" -eq 3 ] || { dry TILES=3 >&2; echo "FAIL: expected 3 band renders at +WT1, found $n" >&2; exit 1; }
n=$(dry TILES=3 POV_THREADS=2 | grep 'render_band\.sh' | grep -c ' +WT2 *$' || true)
[ "$n" -eq 3 ] || { echo "FAIL: POV_THREADS=2: expected 3 band renders at +WT2, found $n" >&2; exit 1; }
whole=$(dry POV_THREADS=2)
grep -q 'render\.sh .* +WT2 *$' <<<"$whole" || { echo "FAIL: POV_THREADS=2 not given to the whole render" >&2; exit 1; }
if dry POV_THREADS=0 >"$tmp/bad"; then echo "FAIL: POV_THREADS=0 accepted" >&2; exit 1; fi
grep -q 'POV_THREADS=0: expected a positive whole number' "$tmp/bad" || { cat "$tmp/bad" >&2; echo "FAIL: no message for POV_THREADS=0" >&2; exit 1; }
echo "ok: bands render with one thread unless POV_THREADS says; POV_THREADS=0 refused"
failures=0
for m in $methods; do
  if oiiotool "$tmp/whole/checker/$m.exr" "$tmp/bands/checker/$m.exr" --fail 0 --warn 0 --diff >"$tmp/diff" 2>&1; then
    echo "ok: $m from 3 bands equals the single render's"
  else
    cat "$tmp/diff" >&2
    echo "FAIL: $m from 3 bands differs from the single render's" >&2
    failures=$((failures + 1))
  fi
done
exit $failures
