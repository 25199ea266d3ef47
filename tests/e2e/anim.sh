#!/usr/bin/env bash
# anim.sh SOURCE_DIR SIPROJECT
#
# End-to-end test of make anim (ctest label e2e): the sweep scene at 24 x 24,
# factor 2, 4 frames of 2 sub-frames at 24 fps, under a temporary OUT. Checks:
#   - the 8 sub-frames: 48 x 48 half EXRs, each sis:time (a string) the time
#     scripts/anim_times.py gives, and that time POV-Ray's clock: the
#     sub-frame equals the closed form of scenes/sweep.pov at that time;
#   - the frames: 4 PNGs per kind (180 degrees, phase 0: frames 0 to 3);
#     ffprobe: the MP4 is H.264, 4 frames of 24 x 24 at 24 fps, the WebP is
#     animated with 4 frames; the page shows both WebPs;
#   - make's dependencies: a second run redoes nothing; FPS=60 forms frames
#     0 to 9 from the same sub-frames without rendering (space-time only: at
#     another rate a frame's shutter may hold no sub-frame); TIME_JITTER=5 gives
#     other times, each inside its own half of its frame;
#   - bad variables stop make before anything is rendered, naming them.
set -euo pipefail

[ $# -eq 2 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT" >&2; exit 64; }
src=$1 siproject=$2
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-anim.XXXXXX")
trap 'rm -rf -- "$tmp"' EXIT
out=$tmp/out
py=$src/.venv/bin/python
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
die() { echo "FAIL: $*" >&2; exit 1; }
mk() {
  local log=$1; shift
  make -C "$src" --no-print-directory -j2 OUT="$out" SIPROJECT="$siproject" \
    SCENE=sweep RES=24 FACTOR=2 FRAMES=4 SUBFRAMES=2 "$@" >"$log" 2>&1
}
dir=$out/anim/sweep-24-f2-24fps-k2

mk "$tmp/run1.log" anim || { cat "$tmp/run1.log" >&2; die "make anim failed"; }
[ "$(grep -c '^render ' "$tmp/run1.log")" -eq 8 ] || fail "expected 8 sub-frame renders"
mapfile -t want < <(python3 "$src/scripts/anim_times.py" --frames 4 --subframes 2 --fps 24)
for n in 0 1 2 3 4 5 6 7; do
  f=$(printf '%s/sub.%04d.exr' "$dir" "$n")
  [ -f "$f" ] || { fail "no $f"; continue; }
  info=$(oiiotool --info -v "$f")
  grep -Eq ': +48 x +48, 3 channel, half openexr' <<<"$info" || fail "$f: not a 48 x 48 half EXR"
  got=$(sed -n 's/^ *sis:time: "\(.*\)"$/\1/p' <<<"$info")
  [ "$got" = "${want[$n]}" ] || fail "$f: sis:time '$got', expected '${want[$n]}'"
done
# the render at its time is the closed form there (SW_V 0.25, ZP_K for 24 px);
# half rounding of values in [0, 1]: 2^-11
PYTHONPATH=$(dirname "$siproject")/../python "$py" - "$dir/sub.0005.exr" "${want[5]}" <<'PY' || fail "sub-frame 5 is not the closed form at its time"
import math, sys
import numpy as np
import siproject
a = siproject.read_image(sys.argv[1])[:, :, 0].astype(np.float64)
t = float(sys.argv[2])
u = (np.arange(48) + 0.5) / 48
U, V = np.meshgrid(u, u)
k = 0.7 * math.pi * 24
f = 0.5 + 0.5 * np.cos(k * ((U - 0.25 * t - 0.5) ** 2 + (V - 0.5) ** 2))
err = np.max(np.abs(a - f))
assert err < 2 ** -11, err
PY
for kind in spacetime average; do
  n=$(ls "$dir/$kind-24fps" | grep -c '^frame\.[0-9]*\.png$' || true)
  [ "$n" -eq 4 ] || fail "$kind: $n frames, expected 4"
  probe=$(ffprobe -v error -count_frames -show_entries stream=codec_name,width,height,nb_read_frames,r_frame_rate \
          -of default=noprint_wrappers=1 "$dir/$kind-24fps.mp4")
  grep -qx 'codec_name=h264' <<<"$probe" || fail "$kind MP4 is not H.264: $probe"
  grep -qx 'width=24' <<<"$probe" && grep -qx 'height=24' <<<"$probe" || fail "$kind MP4 not 24 x 24: $probe"
  grep -qx 'r_frame_rate=24/1' <<<"$probe" || fail "$kind MP4 not 24 fps: $probe"
  grep -qx 'nb_read_frames=4' <<<"$probe" || fail "$kind MP4 has not 4 frames: $probe"
  # an animated WebP: a RIFF WEBP with an ANIM chunk and 4 ANMF frames
  webp=$dir/$kind-24fps.webp
  [ "$(head -c 4 "$webp")" = RIFF ] && grep -aq ANIM "$webp" || fail "$webp is not an animated WebP"
  [ "$(grep -ao ANMF "$webp" | wc -l)" -eq 4 ] || fail "$webp: not 4 frames"
  grep -q "src=\"$kind-24fps.webp\"" "$dir/index-24fps.html" || fail "the page does not show $kind-24fps.webp"
done

mk "$tmp/run2.log" anim || die "second make anim failed"
grep -Eq '^(render|frames) ' "$tmp/run2.log" && fail "second run redid work: $(cat "$tmp/run2.log")"

mk "$tmp/run24.log" FPS=24.0 anim || die "make anim FPS=24.0 failed"
grep -Eq '^(render|frames) ' "$tmp/run24.log" && fail "FPS=24.0 is not the same rate as 24: $(cat "$tmp/run24.log")"
mk "$tmp/run3.log" FRAMES=3 anim || die "make anim FRAMES=3 failed"
grep -q '^render ' "$tmp/run3.log" && fail "FRAMES=3 rendered again"
n=$(ls "$dir/spacetime-24fps" | grep -c '^frame\.[0-9]*\.png$' || true)
[ "$n" -eq 3 ] || fail "FRAMES=3: $n frames, expected 3 (the 4-frame video left in place?)"
probe=$(ffprobe -v error -count_frames -show_entries stream=nb_read_frames,color_space -of default=noprint_wrappers=1 "$dir/spacetime-24fps.mp4")
grep -qx 'nb_read_frames=3' <<<"$probe" || fail "FRAMES=3: the MP4 is not 3 frames: $probe"
grep -qx 'color_space=bt709' <<<"$probe" || fail "the MP4 is not tagged BT.709: $probe"
grep -q '>6 sub-frames rendered' "$dir/index-24fps.html" || grep -q '6 sub-frames rendered' "$dir/index-24fps.html" ||
  fail "the page does not count the 6 sub-frames the frames came from"

mk "$tmp/run60.log" FPS=60 anim || { cat "$tmp/run60.log" >&2; die "make anim FPS=60 failed"; }
grep -q '^render ' "$tmp/run60.log" && fail "FPS=60 rendered again"
n=$(ls "$dir/spacetime-60fps" | grep -c '^frame\.[0-9]*\.png$' || true)
# span [0, 4/24]: frames k with k/60 + 1/120 <= 1/6, k = 0..9
[ "$n" -eq 10 ] || fail "FPS=60: $n frames, expected 10"
[ ! -e "$dir/average-60fps" ] || fail "FPS=60 formed an average"
grep -q 'spacetime-60fps.webp' "$dir/index-60fps.html" || fail "the 60 fps page does not show its frames"

mk "$tmp/jit.log" TIME_JITTER=5 anim-subframes || die "TIME_JITTER=5 failed"
jdir=$out/anim/sweep-24-f2-24fps-k2-j5
for n in 0 1 2 3 4 5 6 7; do
  t=$(oiiotool --info -v "$(printf '%s/sub.%04d.exr' "$jdir" "$n")" | sed -n 's/^ *sis:time: "\(.*\)"$/\1/p')
  awk -v t="$t" -v n="$n" 'BEGIN { lo = n / 48; hi = (n + 1) / 48; exit !(t >= lo && t < hi && t != (n + 0.5) / 48) }' ||
    fail "jittered sub-frame $n at '$t' s: not inside its own cell, or not moved"
done

for bad in "FRAMES=0" "SUBFRAMES=x" "FPS=-1" "TIME_JITTER=a" "ANIM_METHOD=nope" "ANIM_METHOD=box" \
           "SWEEP_PATTERN=dots" "TILES=2" "SHUTTER=400" "SHUTTER_CURVE=nofile.txt" "TIME_DEGREE=4" \
           "TIME_MODEL=spline" "SWEEP_V=fast"; do
  name=$bad
  if make -C "$src" --no-print-directory OUT="$tmp/bad" SIPROJECT="$siproject" SCENE=sweep RES=24 \
       "$bad" anim >"$tmp/bad.log" 2>&1; then
    fail "make anim $bad succeeded"
  fi
  grep -qF "$name" "$tmp/bad.log" || fail "make anim $bad: message does not name $name: $(cat "$tmp/bad.log")"
  [ ! -e "$tmp/bad/anim" ] || fail "make anim $bad left $tmp/bad/anim"
done

[ "$failures" -eq 0 ] || { echo "$failures failure(s)" >&2; exit 1; }
echo "anim: all checks passed"
