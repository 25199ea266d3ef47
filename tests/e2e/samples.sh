#!/usr/bin/env bash
# samples.sh SOURCE_DIR SIPROJECT SIRAYS
#
# End-to-end test of the sample patterns' renders (ctest label e2e; about
# 15 s): a mesh camera of pixel-centre rays (sirays mesh, regular pattern)
# reproduces POV-Ray's own camera on a perspective scene with a rotated
# camera (checker), one aimed by look_at and angle (objects) and an
# orthographic one (zoneplate), allowing 1 % of pixels (edge and horizon
# pixels whose rays land on the other side of an edge by float rounding);
# the regular pattern's positions read as a scattered render give the grid's
# result (normalised rule, to rounding); a render whose pattern metadata is
# missing a key, names an unknown pattern or does not match its size, and
# bands that do not make the pattern's grid, are refused (status 3, the file
# and the problem named, nothing written); make SAMPLES=jitter renders mesh
# bands and forms the images, leaving no band scene behind.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT SIRAYS" >&2; exit 64; }
src=$1 siproject=$2 sirays=$3
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-samples.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
ok() { echo "ok: $*"; }

# POV-Ray 3.7.0 repeats face row 0 (FS#254): one row more, dropped by --row-bug.
bug= extra=0
if povray --version 2>&1 | grep -q 'POV-Ray 3\.7\.0'; then bug=--row-bug extra=1; fi

# 1. pixel-centre rays through the mesh camera against the ordinary camera
W=32 H=24 F=2
RW=$((W * F)) RH=$((H * F))
for scene in checker objects zoneplate; do
  "$sirays" mesh "$src/scenes/$scene.pov" -o "$tmp/$scene-band.pov" --pattern regular --size ${W}x$H --factor $F
  RENDER_MESH_CAMERA=1 bash "$src/scripts/render.sh" "$tmp/$scene-band.pov" "$tmp/$scene-band.exr" $RW $((RH + extra))
  "$sirays" assemble "$tmp/$scene-band.exr" -o "$tmp/$scene-mesh.exr" --pattern regular --size ${W}x$H --factor $F $bug
  bash "$src/scripts/render.sh" "$src/scenes/$scene.pov" "$tmp/$scene-camera.exr" $RW $RH
  if oiiotool "$tmp/$scene-mesh.exr" "$tmp/$scene-camera.exr" --fail 0.002 --failpercent 1 --diff >"$tmp/diff" 2>&1; then
    ok "$scene: the mesh camera's pixel-centre rays reproduce POV-Ray's camera ($(grep -o '[0-9]* pixels ([0-9.e%-]*) over 0.002' "$tmp/diff" || echo 'every pixel'))"
  else
    cat "$tmp/diff" >&2
    fail "$scene: the mesh camera's render differs from POV-Ray's camera"
  fi
done

# 2. the regular pattern read as a scattered render: the grid's projection
r=$tmp/checker-camera.exr
oiiotool "$r" --sattrib sis:pattern regular --sattrib sis:pattern_seed 0 --sattrib sis:pattern_frame ${W}x$H \
  --sattrib sis:pattern_factor $F -o "$tmp/regular.exr"
"$siproject" "$r" -o "$tmp/grid.exr" --size ${W}x$H -d float -q
"$siproject" "$tmp/regular.exr" -o "$tmp/scattered.exr" --size ${W}x$H --rule normalised -d float -q
"$siproject" "$tmp/regular.exr" -o "$tmp/scattered-f.exr" --factor $F --rule normalised -d float -q
if oiiotool "$tmp/scattered.exr" "$tmp/grid.exr" --fail 1e-5 --diff >"$tmp/diff" 2>&1; then
  ok "the regular pattern's render read as scattered samples gives the grid's projection (within 1e-5)"
else
  cat "$tmp/diff" >&2; fail "the regular pattern's scattered projection differs from the grid's"
fi
oiiotool "$tmp/scattered.exr" "$tmp/scattered-f.exr" --fail 0 --warn 0 --diff >/dev/null 2>&1 &&
  ok "--factor $F equals --size ${W}x$H on a pattern's render" || fail "--factor differs from --size on a pattern's render"

# 3. bad pattern metadata: status 3, the file and the key named, no output
refused() {  # NAME EXPECTED-TEXT oiiotool-attributes...
  local name=$1 expect=$2; shift 2
  oiiotool "$r" "$@" -o "$tmp/$name.exr"
  local rc=0
  "$siproject" "$tmp/$name.exr" -o "$tmp/$name-out.exr" --size ${W}x$H 2>"$tmp/err" || rc=$?
  if [ "$rc" -eq 3 ] && grep -qF "$tmp/$name.exr" "$tmp/err" && grep -qF -- "$expect" "$tmp/err" &&
     [ ! -e "$tmp/$name-out.exr" ] && [ -z "$(ls -A "$tmp" | grep "^\.$name-out")" ]; then
    ok "$name: refused ($(head -1 "$tmp/err"))"
  else
    cat "$tmp/err" >&2; fail "$name: expected status 3 naming the file and '$expect', got $rc"
  fi
}
refused missing-seed "sis:pattern_seed" --sattrib sis:pattern jitter --sattrib sis:pattern_frame ${W}x$H \
  --sattrib sis:pattern_factor $F
refused unknown "unknown sample pattern 'halton'" --sattrib sis:pattern halton --sattrib sis:pattern_seed 0 \
  --sattrib sis:pattern_frame ${W}x$H --sattrib sis:pattern_factor $F
refused wrong-size "is $RW x $RH samples, but its pattern" --sattrib sis:pattern sobol --sattrib sis:pattern_seed 1 \
  --sattrib sis:pattern_frame ${W}x$H --sattrib sis:pattern_factor 3
refused bad-seed "sis:pattern_seed '-1'" --sattrib sis:pattern sobol --sattrib sis:pattern_seed -1 \
  --sattrib sis:pattern_frame ${W}x$H --sattrib sis:pattern_factor $F

# 4. bands that do not make the grid: status 3, nothing written
oiiotool "$r" --cut ${RW}x10+0+0 -o "$tmp/short.exr"
rc=0
"$sirays" assemble "$tmp/short.exr" -o "$tmp/asm.exr" --pattern jitter --size ${W}x$H --factor $F 2>"$tmp/err" || rc=$?
if [ "$rc" -eq 3 ] && grep -q "the bands hold 10 rows of rays; the pattern's grid has $RH" "$tmp/err" && [ ! -e "$tmp/asm.exr" ]; then
  ok "a band short of the grid refused ($(cat "$tmp/err"))"
else
  cat "$tmp/err" >&2; fail "a short band: expected status 3, got $rc"
fi
oiiotool "$r" --resize 40x$RH -o "$tmp/narrow.exr"
rc=0
"$sirays" assemble "$tmp/narrow.exr" -o "$tmp/asm.exr" --pattern jitter --size ${W}x$H --factor $F 2>"$tmp/err" || rc=$?
[ "$rc" -eq 3 ] && grep -q "narrow.exr: 40 pixels wide" "$tmp/err" && [ ! -e "$tmp/asm.exr" ] &&
  ok "a band of the wrong width refused" || { cat "$tmp/err" >&2; fail "a narrow band: expected status 3, got $rc"; }

# 4b. a camera sirays cannot aim: status 3, the scene's line named, no band written
printf '#version 3.7;\n// a fisheye\ncamera {\n  fisheye\n  angle 180\n}\n' > "$tmp/fisheye.pov"
printf '#version 3.7;\nsphere { 0, 1 }\n' > "$tmp/nocamera.pov"
for case in "fisheye:fisheye.pov:4: camera: 'fisheye' is not supported by sirays" \
            "nocamera:nocamera.pov: no camera { ... } statement"; do
  name=${case%%:*} expect=${case#*:}
  rc=0
  "$sirays" mesh "$tmp/$name.pov" -o "$tmp/$name-band.pov" --size 4x4 --factor 1 2>"$tmp/err" || rc=$?
  [ "$rc" -eq 3 ] && grep -qF "$expect" "$tmp/err" && [ ! -e "$tmp/$name-band.pov" ] &&
    ok "$name: refused ($(cat "$tmp/err"))" || { cat "$tmp/err" >&2; fail "$name: expected status 3 and '$expect', got $rc"; }
done

# 5. make SAMPLES=jitter: mesh bands rendered in parallel, assembled, projected
if make -C "$src" --no-print-directory -j2 SIPROJECT="$siproject" SIRAYS="$sirays" OUT="$tmp/out" \
     SCENE=checker RES=16 FACTOR=3 SAMPLES=jitter SEED=2 MESH_RAYS=700 METHODS=me-cubic \
     "$tmp/out/checker-jitter-s2/me-cubic.png" >"$tmp/log" 2>&1; then
  bands=$(ls "$tmp/out/render/" | grep -c 'checker-16-f3-jitter-s2-mesh[0-9]*of4\.exr$' || true)
  left=$(ls -A "$tmp/out/render/" | grep -c '\.tmp' || true)
  meta=$(oiiotool --info -v "$tmp/out/render/checker-16-f3-jitter-s2.exr" | grep -c 'sis:pattern' || true)
  if [ "$bands" -eq 4 ] && [ "$left" -eq 0 ] && [ "$meta" -eq 4 ] && [ -s "$tmp/out/checker-jitter-s2/me-cubic.png" ] &&
     ! grep -q "camera" "$tmp/log"; then
    ok "make SAMPLES=jitter: 4 mesh bands, assembled with the pattern's metadata, images formed, no band scene left, no camera warning"
  else
    cat "$tmp/log" >&2; ls -A "$tmp/out/render" >&2
    fail "make SAMPLES=jitter: bands $bands (expected 4), temporary files $left, pattern keys $meta"
  fi
else
  cat "$tmp/log" >&2; fail "make SAMPLES=jitter failed"
fi
rc=0
make -C "$src" --no-print-directory SIPROJECT="$siproject" SIRAYS="$sirays" OUT="$tmp/out" RES=16 \
  SAMPLES=halton scene >"$tmp/log" 2>&1 || rc=$?
[ "$rc" -ne 0 ] && grep -q "SAMPLES=halton: expected regular, jitter, sobol or adaptive" "$tmp/log" &&
  ok "make SAMPLES=halton refused" || { cat "$tmp/log" >&2; fail "make SAMPLES=halton: expected an error"; }
exit $failures
