#!/usr/bin/env bash
# python_doc.sh SOURCE_DIR SIPROJECT SIMETRICS PYTHON MODULE_DIR
#
# docs/python.md's worked example, run as written (ctest label e2e): its sh
# blocks in a copy of the project's make files (the binaries as built, so
# that make renders and does not build), then its Python block with the
# module as built. Checks that every command succeeds, that the example
# prints one line of four finite errors per method, that min-error cubic's
# error is below the conventional filters' at every factor, and that the
# chart it writes is a PNG.
set -euo pipefail

[ $# -eq 5 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT SIMETRICS PYTHON MODULE_DIR" >&2; exit 64; }
src=$1 siproject=$2 simetrics=$3 python=$4 module=$5
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-doc.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
cp -r "$src/Makefile" "$src/scenes" "$src/scripts" "$tmp/"
doc=$src/docs/python.md
# the blocks after the worked example's heading
awk '/^## A worked example/{on=1} on && /^```sh/{f=1;next} on && /^```python/{p=1;next} /^```/{f=0;p=0} f' "$doc" > "$tmp/example.sh"
awk '/^## A worked example/{on=1} on && /^```python/{p=1;next} /^```/{p=0} p' "$doc" > "$tmp/example.py"
[ -s "$tmp/example.sh" ] && [ -s "$tmp/example.py" ] || { echo "FAIL: no example in $doc" >&2; exit 1; }
cd "$tmp"
export SIPROJECT=$siproject SIMETRICS=$simetrics
bash -e example.sh > make.log 2>&1 || { cat make.log >&2; echo "FAIL: the example's make commands" >&2; exit 1; }
PYTHONPATH=$module "$python" example.py > printed.txt 2> python.log || {
  cat python.log >&2; echo "FAIL: the example's Python" >&2; exit 1; }
cat printed.txt
"$python" - printed.txt <<'PY'
import math, sys
rows = {}
for line in open(sys.argv[1]):
    *name, a, b, c, d = line.split()
    rows[" ".join(name)] = [float(x) for x in (a, b, c, d)]
assert set(rows) == {"conventional tent", "Mitchell-Netravali", "min-error cubic"}, rows
assert all(math.isfinite(e) and e > 0 for r in rows.values() for e in r), rows
for i in range(4):
    assert rows["min-error cubic"][i] < min(rows["conventional tent"][i], rows["Mitchell-Netravali"][i]), (i, rows)
PY
head -c 8 out/python-example/error.png | od -An -tx1 | grep -q "89 50 4e 47 0d 0a 1a 0a" || {
  echo "FAIL: out/python-example/error.png is not a PNG" >&2; exit 1; }
echo "docs/python.md: the example ran as written"
