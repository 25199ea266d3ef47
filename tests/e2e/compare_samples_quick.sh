#!/usr/bin/env bash
# compare_samples_quick.sh SOURCE_DIR SIPROJECT SIMETRICS SIRAYS
#
# make compare-samples QUICK=1 on two of its scenes (checker, zoneplate) at one
# density, 4 rays per pixel (ctest label e2e; under a minute): the report has
# a row for every scene, method, density and pattern with finite numbers,
# the chart exists, and a second run renders nothing again (the renders are
# make targets under its one staleness rule).
set -euo pipefail
[ $# -eq 4 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT SIMETRICS SIRAYS" >&2; exit 64; }
src=$1 siproject=$2 simetrics=$3 sirays=$4
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-compare-samples.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
mk() {
  make -C "$src" --no-print-directory SIPROJECT="$siproject" SIMETRICS="$simetrics" SIRAYS="$sirays" \
    OUT="$tmp/out" compare-samples QUICK=1 CS_SCENES="checker zoneplate" CS_FACTORS=2 CS_REF_CHECK= >"$1" 2>&1 || { cat "$1" >&2; fail "make compare-samples QUICK=1"; }
}
mk "$tmp/log1"
md=$tmp/out/report-quick/samples/samples.md
[ -s "$md" ] && [ -s "$tmp/out/report-quick/samples/samples.png" ] && [ -s "$tmp/out/report-quick/samples/samples.csv" ] ||
  fail "the report's files are missing"
rows=$(sed -n '/^## All numbers/,$p' "$md" | grep -cE '^\| (checker|zoneplate) \| ' || true)
[ "$rows" -eq 30 ] || fail "expected 30 rows (2 scenes, 5 methods, 1 density, 3 patterns), found $rows"
grep -qiE '\| (nan|inf)' "$md" && fail "a number is not finite"
echo "ok: 30 rows, finite, chart written"
mk "$tmp/log2"
grep -qE '^(render|assemble) ' "$tmp/log2" && { cat "$tmp/log2" >&2; fail "the second run rendered again"; }
echo "ok: the second run renders nothing"
