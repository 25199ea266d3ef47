#!/usr/bin/env bash
# bench_quick.sh SOURCE_DIR BUILD_DIR
#
# End-to-end test of the benchmark (ctest label e2e): runs scripts/bench.py
# --quick (1000^2 render to 250^2, one round; about 20 s) into a temporary
# folder and checks the report, never the times (a shared machine's timing is
# no test): every competitor has a row with a positive wall time and peak
# memory, each ratio is its wall time over the floor's, siproject's outputs at
# 1 and 2 threads are bit-identical, every target has its verdict line, and
# no temporary file is left; the scattered render's rows (siproject on a
# jitter render and on the regular render of its size) and its mesh bands'
# rows, whose rays add up to the render's. Then a missing binary fails cleanly: exit status
# 1, a message naming it, no report written.
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: ${0##*/} SOURCE_DIR BUILD_DIR" >&2; exit 64; }
src=$(cd "$1" && pwd) build=$(cd "$2" && pwd)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-bench.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
py="$src/.venv/bin/python"
cd "$src"
"$py" scripts/bench.py --quick --build "$build" --outdir "$tmp/bench" > "$tmp/log" 2>&1 ||
  { cat "$tmp/log"; exit 1; }
"$py" - "$tmp/bench" <<'PY'
import csv, os, re, sys
d = sys.argv[1]
left = [f for f in os.listdir(d) if f.startswith(".") or ".tmp" in f]
assert not left, f"temporary files left: {left}"
rows = list(csv.DictReader(open(os.path.join(d, "bench-quick.csv"))))
names = {r["competitor"] for r in rows}
want = ["decode floor (sidecode)", "decode to float (sidecode --as-float)",
        f"decode as siproject reads, a reader per core (sidecode --readers {os.cpu_count() or 1})"]
want += [f"oiiotool {f}" for f in ("box", "triangle", "mitchell", "bspline", "lanczos3")]
want += [f"splineops least-squares degree {d}" for d in (1, 3)]
want += ["siproject min-error cubic 2x2", "siproject min-error cubic centred",
         "siproject min-error tent centred", "siproject conventional tent", "siproject box",
         "siproject mitchell", "siproject min-error cubic 2x2 --threads 1",
         "siproject min-error cubic 2x2 --threads 2"]
missing = [w for w in want if w not in names]
assert not missing, f"competitors missing from the table: {missing}"
assert any(r["group"] == "big" and r["competitor"].startswith("siproject min-error cubic 2x2, ")
           for r in rows), "no run at scale"
scattered = [r for r in rows if r["group"] == "scattered"]
assert [r["competitor"].split(", ")[1].split()[1] for r in scattered] == ["regular", "jitter"], \
    f"the scattered rows: {[r['competitor'] for r in scattered]}"
# both of 500^2 rays (--quick: 125^2 output pixels, factor 4)
assert all(r["input"] == "250000 rays" for r in scattered), [r["input"] for r in scattered]
by = {r["competitor"]: r for r in rows}
floor = float(by["decode floor (sidecode)"]["wall_median_s"])
for r in rows:
    wall, rss = float(r["wall_median_s"]), float(r["peak_rss_mb"])
    assert wall > 0 and rss > 0, f"{r['competitor']}: wall {wall}, peak {rss}"
    if r["group"] not in ("big", "scattered"):
        # the csv rounds walls to 1 ms and ratios to 0.01: the ratio of the
        # rounded walls is off by up to R (0.0005 / wall + 0.0005 / floor)
        ratio = wall / floor
        tol = 0.006 + ratio * (0.0005 / wall + 0.0005 / floor)
        assert abs(float(r["ratio_decode_floor"]) - ratio) <= tol, r
    if r["competitor"].startswith("siproject"):
        assert "total=" in r["stages_median_s"], f"{r['competitor']}: no stage times"
md = open(os.path.join(d, "bench-quick.md")).read()
assert "outputs **bit-identical**" in md, "threads 1 and 2 gave different outputs"
verdicts = re.findall(r"^- (?:met|\*\*not met\*\*): (.*)$", md, re.M)
for target in ("oiiotool bspline time", "the decode floor", "peak memory", "compute stage",
               "bit-identical"):
    assert any(target in v for v in verdicts), f"no verdict on {target}"
# the scattered render's mesh bands, each with its sirays mesh and parse times
band_rows = re.findall(r"^\| (\d+) \| (\d+) \| \d+ \| ([0-9.]+) \| ([0-9.]+) \| ", md, re.M)
assert band_rows and sum(int(b[1]) for b in band_rows) == 250000, f"mesh bands: {band_rows}"
print(f"ok: {len(rows)} rows, {len(verdicts)} verdicts, {len(band_rows)} mesh band(s)")
PY
# a missing binary: status 1, named, nothing written
set +e
"$py" scripts/bench.py --quick --build "$build" --outdir "$tmp/bad" \
  --siproject "$tmp/no-such-siproject" > "$tmp/bad.log" 2>&1
status=$?
set -e
[ "$status" -eq 1 ] || { echo "missing siproject: status $status, expected 1"; cat "$tmp/bad.log"; exit 1; }
grep -q "no-such-siproject" "$tmp/bad.log" || { echo "the message does not name the binary"; cat "$tmp/bad.log"; exit 1; }
[ ! -e "$tmp/bad/bench-quick.md" ] || { echo "a report was written after the error"; exit 1; }
echo "ok: a missing binary fails cleanly"
