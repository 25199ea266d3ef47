#!/usr/bin/env bash
# adaptive.sh SOURCE_DIR SIPROJECT SIRAYS
#
# End-to-end test of adaptive rays (ctest label e2e; about 25 s): make
# SAMPLES=adaptive RAYS=12 on objects at 32 x 32 renders the sobol first pass,
# refines tiles (sirays refine), traces only the extra rays in one POV-Ray
# process (in three under MESH_RAYS=3000, the same images bit for bit),
# forms the images from both passes, and puts rays.png on the scene's
# page; a budget of the base's own rays (RAYS=4) refines nothing and gives
# the uniform sobol render's images bit for bit; bad requests are
# refused with the option or file named and nothing written: a budget below
# the base pattern (make and sirays refine), a refinement of no tile traced
# (an empty region), a tile outside the frame, a tile of 0 pixels, --refined
# with a grid input or with another pattern's render.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT SIRAYS" >&2; exit 64; }
src=$1 siproject=$2 sirays=$3
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-adaptive.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
ok() { echo "ok: $*"; }
mk() { make -C "$src" --no-print-directory SIPROJECT="$siproject" SIRAYS="$sirays" OUT="$tmp/out" \
         SCENE=objects RES=32 METHODS="me-cubic conv-tent" "$@"; }

# 1. make SAMPLES=adaptive RAYS=12: both passes, the images, the picture
if mk SAMPLES=adaptive RAYS=12 >"$tmp/log" 2>&1; then
  d=$tmp/out/objects-adaptive-r12-s0 r=$tmp/out/render/objects-32-adaptive-r12-s0
  tiles=$(awk '$1 == "tiles" { print $2 }' "$r.refine.txt")
  bands=$(grep -c 'the second pass: .* 1 band(s)' "$tmp/log" || true)
  if [ "${tiles:-0}" -gt 0 ] && [ "$bands" -eq 1 ] && [ -s "$d/me-cubic.exr" ] && [ -s "$d/rays.png" ] &&
     grep -q 'src="rays.png"' "$d/index.html" && grep -q "refined to" "$d/rays.txt" &&
     oiiotool --info -v "$r.exr" | grep -q 'sis:refinement' && [ -z "$(ls -A "$tmp/out/render" | grep '\.tmp')" ]; then
    ok "make SAMPLES=adaptive RAYS=12: $tiles tiles refined, one POV-Ray process for the extra rays, rays.png on the page ($(cat "$d/rays.txt"))"
  else
    cat "$tmp/log" >&2; ls -A "$tmp/out/render" "$d" >&2 || true
    fail "make SAMPLES=adaptive RAYS=12: tiles ${tiles:-none}, bands $bands"
  fi
else
  cat "$tmp/log" >&2; fail "make SAMPLES=adaptive RAYS=12 failed"
fi

# 1b. the second pass in bands of MESH_RAYS=3000 (3 POV-Ray processes): the same images
if make -C "$src" --no-print-directory SIPROJECT="$siproject" SIRAYS="$sirays" OUT="$tmp/banded" \
     SCENE=objects RES=32 METHODS="me-cubic conv-tent" SAMPLES=adaptive RAYS=12 MESH_RAYS=3000 >"$tmp/log" 2>&1 &&
   grep -q 'the second pass: .* 3 band(s)' "$tmp/log" &&
   oiiotool "$tmp/banded/objects-adaptive-r12-s0/me-cubic.exr" "$tmp/out/objects-adaptive-r12-s0/me-cubic.exr" \
     --fail 0 --warn 0 --diff >"$tmp/diff" 2>&1; then
  ok "MESH_RAYS=3000: the second pass in 3 bands gives the one band's images bit for bit"
else
  cat "$tmp/log" "$tmp/diff" >&2; fail "MESH_RAYS=3000: the banded second pass differs or failed"
fi

# 2. nothing refined: the uniform sobol render's images, bit for bit
if mk SAMPLES=adaptive RAYS=4 >"$tmp/log" 2>&1 && mk SAMPLES=sobol FACTOR=2 >>"$tmp/log" 2>&1; then
  a=$tmp/out/objects-adaptive-r4-s0 u=$tmp/out/objects-sobol-s0
  same=1
  for m in me-cubic conv-tent; do
    oiiotool "$a/$m.exr" "$u/$m.exr" --fail 0 --warn 0 --diff >"$tmp/diff" 2>&1 || same=0
    cmp -s "$a/$m.png" "$u/$m.png" || same=0
  done
  if [ "$(awk '$1 == "tiles" { print $2 }' "$tmp/out/render/objects-32-adaptive-r4-s0.refine.txt")" = 0 ] && [ $same -eq 1 ]; then
    ok "RAYS=4 (the base's own): no tile refined, no ray traced, every image equals the uniform sobol render's bit for bit"
  else
    cat "$tmp/diff" >&2; fail "RAYS=4: the images differ from the uniform render's"
  fi
else
  cat "$tmp/log" >&2; fail "make SAMPLES=adaptive RAYS=4 or SAMPLES=sobol FACTOR=2 failed"
fi

# 2b. RULE: below 4 rays per pixel (RULE=auto) me-cubic fits the rays by
# the variational rule, siproject's own result bit for bit; conv-tent keeps
# its normalised rule; RULE=fit is the fit
if mk SAMPLES=sobol FACTOR=1 >"$tmp/log" 2>&1; then
  r=$tmp/out/render/objects-32-f1-sobol-s0.exr u=$tmp/out/objects-sobol-s0
  "$siproject" "$r" --size 32x32 --generator cubic --method min-error --display centred --rule variational \
    -o "$tmp/v.exr" -d float -q
  "$siproject" "$r" --size 32x32 --generator cubic --method min-error --display centred -o "$tmp/f.exr" -d float -q
  if oiiotool "$u/me-cubic.exr" "$tmp/v.exr" --fail 0 --warn 0 --diff >"$tmp/diff" 2>&1 &&
     ! oiiotool "$u/me-cubic.exr" "$tmp/f.exr" --fail 0 --warn 0 --diff >/dev/null 2>&1 &&
     grep -q -- "--rule variational" "$u/.me-cubic.cmd" && ! grep -q -- "--rule" "$u/.conv-tent.cmd" &&
     mk -n SAMPLES=sobol FACTOR=1 METHODS="hex-hat hex-quartic" >"$tmp/plan" 2>&1 &&
     grep -q -- "--generator hex-hat --display centred --rule variational --smoothness 1" "$tmp/plan" &&
     grep -q -- "--generator hex-quartic --display centred --rule variational" "$tmp/plan" &&
     mk SAMPLES=sobol FACTOR=1 RULE=fit >"$tmp/log" 2>&1 &&
     oiiotool "$u/me-cubic.exr" "$tmp/f.exr" --fail 0 --warn 0 --diff >"$tmp/diff" 2>&1; then
    ok "RULE=auto at 1 ray per pixel: me-cubic by the variational rule (siproject's bits), hex-quartic too, hex-hat of order 1, conv-tent as before; RULE=fit: the fit"
  else
    cat "$tmp/log" "$tmp/diff" >&2; fail "RULE: me-cubic at 1 ray per pixel is not the rule's result"
  fi
else
  cat "$tmp/log" >&2; fail "make SAMPLES=sobol FACTOR=1 failed"
fi

# 3. refusals
expect() {  # NAME STATUS TEXT command...
  local name=$1 status=$2 text=$3; shift 3
  local rc=0
  "$@" >"$tmp/err" 2>&1 || rc=$?
  if [ "$rc" -eq "$status" ] && grep -qF -- "$text" "$tmp/err"; then
    ok "$name: refused ($(grep -F -- "$text" "$tmp/err" | head -1))"
  else
    cat "$tmp/err" >&2; fail "$name: expected status $status and '$text', got $rc"
  fi
}
base=$tmp/out/render/objects-32-f2-sobol-s0.exr
expect "make: a budget below the base" 2 "RAYS=2 is below the first pass's ADAPT_BASE=4" mk SAMPLES=adaptive RAYS=2 ADAPT_BASE=4
expect "make: no budget" 2 "SAMPLES=adaptive needs RAYS=N" mk SAMPLES=adaptive
expect "make: an unknown rule" 2 "RULE=normalised: expected auto, fit or variational" mk SAMPLES=sobol RULE=normalised
expect "make: a base of 2 rays" 2 "ADAPT_BASE=2: the first pass's rays per pixel must be the square" mk SAMPLES=adaptive RAYS=8 ADAPT_BASE=2
expect "sirays refine: a budget below the base" 2 "--rays 3: a budget of 3 rays per pixel is below the base pattern's 4" \
  "$sirays" refine "$base" -o "$tmp/r.txt" --rays 3
[ ! -e "$tmp/r.txt" ] || fail "sirays refine --rays 3 wrote $tmp/r.txt"
expect "sirays refine: a tile of 0 pixels" 2 "--tile 0" "$sirays" refine "$base" -o "$tmp/r.txt" --rays 8 --tile 0
"$sirays" refine "$base" -o "$tmp/none.txt" --rays 4 2>/dev/null
expect "an empty region traced" 2 "refines no tile: there are no extra rays to trace" \
  "$sirays" mesh "$src/scenes/objects.pov" -o "$tmp/none.pov" --refinement "$tmp/none.txt"
[ ! -e "$tmp/none.pov" ] || fail "sirays mesh of no ray wrote a scene"
sed 's/^tiles 0$/tiles 1\n16/' "$tmp/none.txt" > "$tmp/outside.txt"
expect "a tile outside the frame" 3 "tile 16 lies outside the frame: 32 x 32 pixels make 4 x 4 tiles" \
  "$sirays" mesh "$src/scenes/objects.pov" -o "$tmp/outside.pov" --refinement "$tmp/outside.txt"
r12=$tmp/out/render/objects-32-adaptive-r12-s0.exr
expect "--refined with a grid input" 2 "--refined $r12: the second pass refines a sobol render's samples" \
  "$siproject" "$tmp/out/objects-sobol-s0/me-cubic.exr" --refined "$r12" -o "$tmp/g.exr" --size 32x32
mk SAMPLES=sobol FACTOR=2 SEED=1 render >/dev/null 2>&1
expect "--refined with another seed's render" 3 "refines pattern sobol seed 0 frame 32x32 factor 2; objects-32-f2-sobol-s1.exr is sobol seed 1" \
  "$siproject" "$tmp/out/render/objects-32-f2-sobol-s1.exr" --refined "$r12" -o "$tmp/s.exr" --size 32x32
[ ! -e "$tmp/s.exr" ] && [ ! -e "$tmp/g.exr" ] || fail "a refused --refined wrote its output"
exit $failures
