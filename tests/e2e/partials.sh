#!/usr/bin/env bash
# partials.sh SOURCE_DIR SIPROJECT
#
# siproject --partial / --merge end to end, on an image oiiotool writes and
# crops: the partials of 3 row bands cut at siproject --band-cuts, merged in
# shuffled order, give the single run's pixels bit for bit (EXR and PNG, both
# lattices, with --clamp local); the Makefile cuts its tiles where
# --band-cuts does; misaligned rows, a gap, an overlap, other options and a
# partial to PNG are refused (exit 2) leaving no file.
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT" >&2; exit 64; }
src=$1 siproject=$2
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-partials.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
cd "$tmp"
fail() { echo "FAIL: $*" >&2; exit 1; }

# the Makefile's tile cuts are siproject's
for spec in "2000 3" "2048 7" "600 2" "100 1"; do
  set -- $spec
  want=$("$siproject" --band-cuts "$1,$2")
  got=$(make -s -C "$src" band-cuts RES=$1 FACTOR=1 TILES=$2)
  [ "$want" = "$got" ] || fail "make band-cuts RES=$1 TILES=$2 gives '$got', siproject '$want'"
done
echo "ok: make's tile cuts are siproject --band-cuts"

oiiotool --pattern fill:topleft=0,0,0:topright=1,0.5,0:bottomleft=0,0,1:bottomright=1,1,1 320x1100 3 \
  --pattern checker:width=7:height=5 320x1100 3 --add -d half -o in.exr
read -r y0 y1 y2 y3 <<<"$("$siproject" --band-cuts 1100,3)"
crop() { oiiotool in.exr --crop "320x$(($2 - $1))+0+$1" -o "$3"; }
crop "$y0" "$y1" b0.exr
crop "$y1" "$y2" b1.exr
crop "$y2" "$y3" b2.exr

for opts in "--factor 4 --clamp local" "--factor 4 --lattice hex --generator hex-hat --density 1.5" \
            "--factor 4 --generator tent --method conventional"; do
  projection=( $opts )
  partial=()
  for o in "${projection[@]}"; do [ "$o" = "--clamp" ] || [ "$o" = local ] || partial+=("$o"); done
  "$siproject" in.exr -o whole.exr "${projection[@]}" -q
  "$siproject" in.exr -o whole.png "${projection[@]}" -q
  for i in 0 1 2; do "$siproject" b$i.exr --partial -o p$i.exr "${partial[@]}" -q; done
  view=(); [[ "$opts" == *"clamp local"* ]] && view=(--clamp local)
  "$siproject" --merge p2.exr p0.exr p1.exr -o merged.exr "${view[@]}" -q
  "$siproject" --merge p1.exr p2.exr p0.exr -o merged.png "${view[@]}" -q
  oiiotool whole.exr merged.exr --fail 0 --warn 0 --diff >/dev/null || fail "$opts: merged EXR differs"
  oiiotool whole.png merged.png --fail 0 --warn 0 --diff >/dev/null || fail "$opts: merged PNG differs"
  echo "ok: $opts: 3 partials merged in shuffled order equal the single run"
done

refused() {  # refused WHAT OUTPUT ARGS...: exit 2, OUTPUT not written
  local what=$1 out=$2; shift 2
  rm -f "$out"
  set +e; "$siproject" "$@" 2>err.txt; rc=$?; set -e
  [ $rc -eq 2 ] || { cat err.txt >&2; fail "$what: exit $rc, expected 2"; }
  [ ! -e "$out" ] || fail "$what: $out written"
  echo "ok: $what refused: $(head -c 160 err.txt)"
}
oiiotool in.exr --crop 320x300+0+100 -o off.exr
refused "rows not whole bands" p.exr off.exr --partial -o p.exr --factor 4
refused "a gap" m.png --merge p0.exr p2.exr -o m.png
refused "an overlap" m.png --merge p0.exr p1.exr p1.exr p2.exr -o m.png
"$siproject" b1.exr --partial -o q1.exr --factor 4 --generator quadratic -q
refused "other options" m.png --merge p0.exr q1.exr p2.exr -o m.png
refused "a partial to PNG" p.png b0.exr --partial -o p.png --factor 4
refused "a partial with a display" p.exr b0.exr --partial -o p.exr --factor 4 --display pixel
refused "partials with a plain image" m.png --merge p0.exr in.exr -o m.png
leftover=$(ls -A | grep -v -E '^(in|off|b[0-2]|p[0-2]|q1|whole|merged)\.(exr|png)$|^err\.txt$' || true)
[ -z "$leftover" ] || fail "files left: $leftover"
echo "ok: no temporary file left"
