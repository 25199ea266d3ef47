#!/usr/bin/env bash
# pipeline.sh SOURCE_DIR SIPROJECT SIMETRICS
#
# End-to-end test of the make pipeline (ctest label e2e): the project's
# Makefile renders the checker scene through POV-Ray at 64 x 64, factor 4
# (256 x 256 rays, antialiasing off), forms every method with SIPROJECT and
# summarises with SIMETRICS, all under a temporary OUT folder. Checks:
#   - sizes: the render is 256 x 256, every EXR and PNG 64 x 64;
#   - every EXR is finite (oiiotool --stats: no NaN, no Inf);
#   - min-error tent has a larger high-pass share than conventional tent at
#     both summary cutoffs (docs/design.md section 4: the seed's ordering);
#   - make's dependencies: a second run redoes nothing; a new FACTOR
#     re-renders and re-projects; going back re-projects from the render
#     already there; changed options of one method redo only that method;
#   - a POV-Ray parse error stops make, shows POV-Ray's message and status,
#     and leaves no render behind.
set -euo pipefail

[ $# -eq 3 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT SIMETRICS" >&2; exit 64; }
src=$1 siproject=$2 simetrics=$3

# Run as a fresh make, not as a child of the make that may have started ctest.
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-e2e.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
out=$tmp/out
methods=(box conv-tent me-tent mitchell me-cubic me-tent-2x2 me-cubic-2x2)

failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
die() { echo "FAIL: $*" >&2; exit 1; }

# mk LOG [VAR=value...] [GOAL...]: make on the checker scene, 64 x 64, factor 4
# unless the arguments say otherwise; stdout and stderr to LOG.
mk() {
  local log=$1; shift
  make -C "$src" --no-print-directory OUT="$out" SIPROJECT="$siproject" SIMETRICS="$simetrics" \
    SCENE=checker RES=64 FACTOR=4 "$@" >"$log" 2>&1
}
# count WORDS LOG: lines of LOG that start with one of WORDS (an ERE such as
# render|project) and a blank: the renders and projections make reported.
count() { grep -Ec "^($1) " "$2" || true; }
# describe FILE...: one line per file, "NAME WxH CHANNELS TYPE NAN INF FINITE",
# from a single oiiotool --stats (counts per channel joined by commas).
describe() {
  oiiotool --stats "$@" 2>/dev/null | awk '
    function flush() { if (name != "") print name, size, ch, type, nan, inf, fin }
    / : *[0-9]+ x *[0-9]+, [0-9]+ channel, / {
      flush()
      name = $1; line = $0; sub(/^[^:]*: */, "", line)
      split(line, f, /[ ,]+/)          # W x H channel-count "channel" type format
      size = f[1] "x" f[3]; ch = f[4]; type = f[6]; nan = inf = fin = "?"
      next
    }
    function counts(   i, s) { s = $3; for (i = 4; i <= NF; i++) s = s "," $i; return s }
    /Stats NanCount:/ { nan = counts() }
    /Stats InfCount:/ { inf = counts() }
    /Stats FiniteCount:/ { fin = counts() }
    END { flush() }'
}

# --- the full pipeline ------------------------------------------------------------
mk "$tmp/run1.log" scene || { cat "$tmp/run1.log" >&2; die "make failed"; }
[ "$(count render "$tmp/run1.log")" -eq 1 ] || fail "first run: expected one render"
[ "$(count project "$tmp/run1.log")" -eq ${#methods[@]} ] || fail "first run: expected ${#methods[@]} projections"
grep -q '^method ' "$tmp/run1.log" || fail "first run printed no summary table"

# The scene's page: every image it names loads in a real browser (headless
# Chromium; the page marks how many loaded once the load event has fired).
page=$out/checker/index.html
if [ -f "$page" ]; then
  dom=$(timeout 120 chromium --headless --no-sandbox --disable-gpu --virtual-time-budget=5000 \
             --dump-dom "file://$page" 2>/dev/null || true)
  loaded=$(grep -o 'data-loaded="[^"]*"' <<<"$dom" || true)
  want=$(grep -o '<img ' "$page" | wc -l)  # each image and its crops (one at 64 x 64)
  [ "$want" -ge $(( ${#methods[@]} * 2 )) ] || fail "$page names $want images, fewer than an image and a crop per method"
  [ "$loaded" = "data-loaded=\"$want of $want\"" ] || fail "$page: images loaded: ${loaded:-none reported} (expected $want of $want)"
  # the crops at their stated enlargement (4 x 64 CSS pixels, pixelated), each a link to itself
  crops=$(grep -o '<img class="crop"' "$page" | wc -l)
  [ "$crops" -eq ${#methods[@]} ] || fail "$page: $crops crops, expected one per method"
  shown=$(grep -o 'data-crops="[^"]*"' <<<"$dom" || true)
  [ "$shown" = "data-crops=\"$crops of $crops\"" ] || fail "$page: crops at their enlargement: ${shown:-none reported} (expected $crops of $crops)"
  [ "$(grep -o '<a href="crops/[^"]*"><img class="crop"' "$page" | wc -l)" -eq "$crops" ] || fail "$page: a crop without its link"
  grep -q 'min-error (orthogonal projection onto the space), cubic B-spline' "$page" || fail "$page does not spell out me-cubic"
else
  fail "no $page"
fi

render=$out/render/checker-64-f4.exr
files=("$render")
for m in "${methods[@]}"; do files+=("$out/checker/$m.exr" "$out/checker/$m.png"); done
describe "${files[@]}" >"$tmp/describe.txt"
for f in "${files[@]}"; do
  case $f in
    *.png) want="64x64 3 uint8" ;;
    "$render") want="256x256 3 half" ;;
    *) want="64x64 3 float" ;;
  esac
  got=$(awk -v f="$f" '$1 == f' "$tmp/describe.txt")
  read -r _ size ch type nan inf fin <<<"${got:-? ? ? ? ? ? ?}"
  [ "$size $ch $type" = "$want" ] || fail "$f: $size $ch $type, expected $want"
  n=?
  [[ $size =~ ^([0-9]+)x([0-9]+)$ ]] && n=$(( BASH_REMATCH[1] * BASH_REMATCH[2] ))
  [ "$nan $inf" = "0,0,0 0,0,0" ] && [ "$fin" = "$n,$n,$n" ] ||
    fail "$f: not finite: NaN $nan, Inf $inf, finite $fin of $n per channel"
done

# High-pass shares from the summary's CSV (simetrics): columns method,time_s,hp_0.125,hp_0.25.
csv=$out/checker/summary.csv
[ "$(head -n 1 "$csv")" = "method,time_s,hp_0.125,hp_0.25" ] || fail "$csv header: $(head -n 1 "$csv")"
for col in 3 4; do
  name=$(head -n 1 "$csv" | cut -d, -f"$col")
  ct=$(awk -F, '$1 == "conv-tent" { print $'"$col"' }' "$csv")
  me=$(awk -F, '$1 == "me-tent" { print $'"$col"' }' "$csv")
  [ -n "$ct" ] && [ -n "$me" ] || { fail "$csv: no $name for conv-tent or me-tent"; continue; }
  awk -v a="$me" -v b="$ct" 'BEGIN { exit !(a > b && b > 0 && a < 1) }' ||
    fail "$name: min-error tent $me should exceed conventional tent $ct (both in (0, 1))"
  echo "$name: conventional tent $ct, min-error tent $me"
done

# --- make's dependencies ------------------------------------------------------------
# A second run redoes nothing: every file keeps its inode (results are renamed
# into place, so a redone file gets a new one) and its time.
snapshot() { stat -c '%n %i %.9Y' "$render" "$out"/checker/*.exr "$out"/checker/*.png "$out"/checker/*.log; }
before=$(snapshot)
mk "$tmp/run2.log" scene || { cat "$tmp/run2.log" >&2; die "second make failed"; }
[ "$(count 'render|project' "$tmp/run2.log")" -eq 0 ] ||
  fail "second run redid work: $(grep -E '^(render|project) ' "$tmp/run2.log")"
[ "$(snapshot)" = "$before" ] || fail "second run changed files"
grep -q '^method ' "$tmp/run2.log" || fail "second run printed no summary table"

# The rest makes two images only (no summary), to stay quick.
two=("$out/checker/conv-tent.exr" "$out/checker/me-tent.exr")
mk "$tmp/run3.log" "${two[@]}" FACTOR=2 || { cat "$tmp/run3.log" >&2; die "make FACTOR=2 failed"; }
[ "$(count render "$tmp/run3.log")" -eq 1 ] || fail "FACTOR=2 did not re-render"
[ "$(count project "$tmp/run3.log")" -eq 2 ] || fail "FACTOR=2 did not redo both methods"
describe "$out/render/checker-64-f2.exr" "$out/checker/me-tent.exr" >"$tmp/describe2.txt"
[ "$(awk '{ print $2, $3, $4 }' "$tmp/describe2.txt" | tr '\n' ' ')" = "128x128 3 half 64x64 3 float " ] ||
  fail "FACTOR=2: render and result sizes: $(cat "$tmp/describe2.txt")"

mk "$tmp/run4.log" "${two[@]}" || { cat "$tmp/run4.log" >&2; die "make back to FACTOR=4 failed"; }
[ "$(count render "$tmp/run4.log")" -eq 0 ] || fail "back to FACTOR=4 re-rendered"
[ "$(count project "$tmp/run4.log")" -eq 2 ] || fail "back to FACTOR=4 did not redo both methods"

mk "$tmp/run5.log" "${two[@]}" METHOD_OPTS_me-tent='--generator tent --method min-error --display pixel' ||
  { cat "$tmp/run5.log" >&2; die "make with other me-tent options failed"; }
[ "$(count render "$tmp/run5.log")" -eq 0 ] && [ "$(count project "$tmp/run5.log")" -eq 1 ] ||
  fail "a changed option should redo exactly one method: $(grep -E '^(render|project) ' "$tmp/run5.log")"

# --- a POV-Ray error stops make with POV-Ray's message -----------------------------
mkdir "$tmp/scenes"
printf '#version 3.7;\ncamera { location <0, 0, -2> look_at 0 }\nsphere { 0, 1 pigment { rgb 1 }\n' \
  >"$tmp/scenes/broken.pov"
if mk "$tmp/run6.log" SCENEDIR="$tmp/scenes" SCENE=broken scene; then
  fail "make succeeded on a broken scene"
fi
grep -q 'Parse Error' "$tmp/run6.log" || fail "POV-Ray's parse error is not shown"
grep -q 'povray failed with status 1' "$tmp/run6.log" || fail "POV-Ray's exit status is not shown"
grep -q 'Error 1' "$tmp/run6.log" || fail "make did not stop on the render's status 1"
[ -z "$(find "$out/render" -name '*broken*' ! -name '.*.cmd')" ] || fail "a failed render left files behind"
if grep -qi 'povray.conf' "$tmp"/run*.log; then
  fail "a POV-Ray configuration warning reached the user"
fi

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed; logs:" >&2
  for f in "$tmp"/run*.log; do echo "== $f" >&2; cat "$f" >&2; done
  exit 1
fi
echo "e2e pipeline: all checks passed"
