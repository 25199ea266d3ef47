#!/usr/bin/env bash
# readme.sh SOURCE_DIR SIPROJECT SIMETRICS
#
# The README's examples run as written (ctest label e2e): in a copy of the
# project's make files with the built binaries and .venv linked in, the
# default scene's render is made first (as make makes it), then every line
# of the README's Examples block and its From Python block runs; the files
# they name must exist with the sizes the README says. make uses the binaries
# as built (SIPROJECT, SIMETRICS in the environment), so it renders and does
# not build.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT SIMETRICS" >&2; exit 64; }
src=$1 siproject=$2 simetrics=$3
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-readme.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
cp -r "$src/Makefile" "$src/scenes" "$src/scripts" "$src/README.md" "$tmp/"
mkdir -p "$tmp/build/tools"
ln -s "$siproject" "$tmp/build/tools/siproject"
ln -s "$simetrics" "$tmp/build/tools/simetrics"
ln -s "$src/.venv" "$tmp/.venv"
cd "$tmp"
export SIPROJECT=$tmp/build/tools/siproject SIMETRICS=$tmp/build/tools/simetrics
make --no-print-directory out/render/checker-1000-f4.exr > make.log 2>&1 || { cat make.log >&2; fail "the default render"; }
awk '/^## Examples/{on=1} on && /^```sh/{f=1;next} /^```/{if(f)exit; f=0} f' README.md > examples.sh
awk '/^## From Python/{on=1} on && /^```python/{f=1;next} /^```/{if(f)exit; f=0} f' README.md > example.py
[ "$(wc -l < examples.sh)" -ge 4 ] && [ -s example.py ] || fail "no examples found in README.md"
while IFS= read -r line; do
  [ -z "$line" ] && continue
  echo "+ $line"
  bash -c "$line" > line.log 2>&1 || { cat line.log >&2; fail "README example failed: $line"; }
done < examples.sh
.venv/bin/python example.py || fail "README's Python example"
size() { oiiotool --info "$1" 2>/dev/null | sed -n 's/.* : *\([0-9]*\) x *\([0-9]*\),.*/\1x\2/p'; }
[ "$(size out/final.png)" = 1000x1000 ] || fail "out/final.png is $(size out/final.png)"
[ "$(size out/mitchell.exr)" = 1920x1080 ] || fail "out/mitchell.exr is $(size out/mitchell.exr)"
[ "$(size out/big.png)" = 2000x2000 ] || fail "out/big.png is $(size out/big.png)"
[ -f out/coeffs.exr ] && [ -f out/zoneplate/index.html ] && [ -f out/zoneplate/summary.txt ] ||
  fail "the coefficient file or the zone plate's results are missing"
echo "README.md: every example ran as written"
