#!/usr/bin/env bash
# compare_quick.sh SOURCE_DIR SIPROJECT SIMETRICS
#
# End-to-end test of `make compare QUICK=1` (ctest label e2e): three scenes at
# 64 x 64, factors 1 2 4, a reference at factor 8, every method and two
# POV-Ray antialiasing baselines, all under a temporary OUT folder. Checks:
#   - the report exists and every file it names (img src, a href) exists,
#     by a relative path inside the report folder (no network, no absolute
#     path), and every CSV it names has a header and rows;
#   - results.json has a row for every (scene, method) pair, methods and
#     baselines, with finite numbers (times, continuous L2 error, RMS, PSNR,
#     high-pass shares, overshoot);
#   - a second run remakes nothing (renders, projections and measures reused)
#     and leaves the report in place;
#   - an unknown scene stops make with a message and a non-zero status, and
#     leaves the report as it was.
set -euo pipefail

[ $# -eq 3 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT SIMETRICS" >&2; exit 64; }
src=$1 siproject=$2 simetrics=$3
python=$src/.venv/bin/python
[ -x "$python" ] || { echo "FAIL: $python missing (run scripts/setup.sh)" >&2; exit 1; }

unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-compare.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
out=$tmp/out
report=$out/report-quick

failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
die() { echo "FAIL: $*" >&2; exit 1; }
# Private copies: a rebuild of the tree during the test cannot change the
# binaries between the runs (the second run must find nothing to remake).
mkdir "$tmp/bin"
cp "$siproject" "$tmp/bin/siproject" && cp "$simetrics" "$tmp/bin/simetrics" || die "cannot copy the binaries"
siproject=$tmp/bin/siproject simetrics=$tmp/bin/simetrics
mk() {
  local log=$1; shift
  make -C "$src" --no-print-directory OUT="$out" SIPROJECT="$siproject" SIMETRICS="$simetrics" \
    QUICK=1 "$@" compare >"$log" 2>&1
}

start=$(date +%s)
mk "$tmp/run1.log" || { cat "$tmp/run1.log" >&2; die "make compare QUICK=1 failed"; }
echo "first run: $(( $(date +%s) - start )) s"
[ -f "$report/index.html" ] || die "no $report/index.html"

# The report's links and the results, checked in Python.
"$python" - "$report" <<'EOF' || fail "report checks (above)"
import csv, html.parser, json, math, os, sys
report = sys.argv[1]
bad = []

class Links(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.links = []
    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img" and "src" in a:
            self.links.append(a["src"])
        if tag == "a" and "href" in a:
            self.links.append(a["href"])
        if tag in ("link", "script") and (a.get("href") or a.get("src")):
            self.links.append(a.get("href") or a.get("src"))

p = Links()
with open(os.path.join(report, "index.html"), encoding="utf-8") as f:
    p.feed(f.read())
if not p.links:
    bad.append("index.html names no file")
imgs = 0
for link in p.links:
    if link.startswith("#"):
        continue
    if "://" in link or link.startswith("/") or link.startswith("data:"):
        bad.append(f"not a relative link: {link}")
        continue
    path = os.path.normpath(os.path.join(report, link))
    if not path.startswith(os.path.abspath(report) + os.sep):
        bad.append(f"link leaves the report folder: {link}")
    elif not os.path.isfile(path) or os.path.getsize(path) == 0:
        bad.append(f"missing or empty: {link}")
    elif link.endswith(".png"):
        imgs += 1
    elif link.endswith(".csv"):
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        if len(rows) < 2:
            bad.append(f"{link}: no rows")
if imgs < 10:
    bad.append(f"only {imgs} images linked")

with open(os.path.join(report, "results.json")) as f:
    res = json.load(f)
meta, rows = res["meta"], res["rows"]
names = list(meta["methods"]) + ["pov-" + a for a in meta["aa"]]
fields = ["total_s", "render_s", "project_s", "l2", "rms", "psnr", "hp_0.125", "hp_0.25",
          "max_overshoot", "max_undershoot", "negative_pixels", "rays_per_pixel"]
for s in meta["scenes"]:
    for m in names:
        rs = [r for r in rows if r["scene"] == s and r["method"] == m]
        if not rs:
            bad.append(f"results.json: no row for ({s}, {m})")
        for r in rs:
            for k in fields:
                v = r.get(k)
                if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                    bad.append(f"results.json: ({s}, {m}, factor {r.get('factor')}) {k} = {v!r}")
want = len(meta["scenes"]) * (len(meta["factors"]) * len(meta["methods"]) + len(meta["aa"]))
if len(rows) != want:
    bad.append(f"results.json: {len(rows)} rows, expected {want}")
if not res.get("findings"):
    bad.append("results.json: no findings")
for b in bad:
    print("  " + b, file=sys.stderr)
print(f"report: {len(p.links)} links, {imgs} images, {len(rows)} result rows")
sys.exit(1 if bad else 0)
EOF
grep -q '^## Results' "$report/README-results.md" || fail "README-results.md has no '## Results'"

# A second run remakes nothing.
before=$(stat -c '%i %Y' "$out"/compare-quick/render/*.exr | md5sum)
mk "$tmp/run2.log" || { cat "$tmp/run2.log" >&2; die "second make compare QUICK=1 failed"; }
if grep -Eq '^(render|project|measure) ' "$tmp/run2.log"; then
  fail "second run remade work: $(grep -E '^(render|project|measure) ' "$tmp/run2.log" | head -5)"
fi
[ "$(stat -c '%i %Y' "$out"/compare-quick/render/*.exr | md5sum)" = "$before" ] || fail "second run touched the renders"
grep -q '(0 renders, 0 projections, 0 measures made' "$tmp/run2.log" || fail "second run: $(tail -n 1 "$tmp/run2.log")"
[ -f "$report/index.html" ] || fail "second run: no index.html"

# An unknown scene: a message, a non-zero status, the report untouched.
sum_before=$(md5sum "$report/index.html")
if mk "$tmp/run3.log" COMPARE_SCENES=nosuchscene; then
  fail "make compare succeeded with an unknown scene"
fi
grep -q 'no scene .*nosuchscene' "$tmp/run3.log" || fail "unknown scene: no message naming it: $(cat "$tmp/run3.log")"
[ "$(md5sum "$report/index.html")" = "$sum_before" ] || fail "a failed run changed the report"
[ -z "$(find "$out" -name '.*tmp*' -o -name 'compare-scratch.*' -o -name 'compare-bin.*')" ] ||
  fail "temporary files left behind: $(find "$out" -name '.*tmp*' -o -name 'compare-scratch.*' -o -name 'compare-bin.*')"

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed; logs:" >&2
  for f in "$tmp"/run*.log; do echo "== $f" >&2; tail -n 40 "$f" >&2; done
  exit 1
fi
echo "compare quick: all checks passed"
