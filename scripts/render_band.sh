#!/usr/bin/env bash
# render_band.sh SCENE.pov OUT.exr WIDTH HEIGHT Y0 Y1 [extra povray options...]
#
# Renders rows [Y0, Y1) of SCENE.pov's WIDTH x HEIGHT frame to OUT.exr (half
# float, its data window those rows): POV-Ray renders the full frame with only
# those rows traced (scripts/render.sh with +SR/+ER, which count rows from 1;
# 3.7 writes the rest black), oiiotool crops it to them. Temporary files
# beside OUT, removed on failure and on signals; OUT is renamed into place
# only when whole. Exits with the failing tool's status (64: usage).
set -euo pipefail
prog=${0##*/}
[ $# -ge 6 ] || { echo "usage: $prog SCENE.pov OUT.exr WIDTH HEIGHT Y0 Y1 [povray options...]" >&2; exit 64; }
scene=$1 out=$2 width=$3 height=$4 y0=$5 y1=$6
shift 6
[[ $y0 =~ ^[0-9]+$ && $y1 =~ ^[0-9]+$ ]] && [ "$y0" -lt "$y1" ] ||
  { echo "$prog: rows must be whole numbers Y0 < Y1: '$y0' '$y1'" >&2; exit 64; }
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd -P)
t=$(dirname -- "$out")/.$(basename -- "$out").tmp$$
trap 'rm -f -- "$t-frame.exr" "$t.exr"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
bash "$here/render.sh" "$scene" "$t-frame.exr" "$width" "$height" "$@" +SR$((y0 + 1)) +ER"$y1"
oiiotool "$t-frame.exr" --crop "${width}x$((y1 - y0))+0+$y0" -d half -o "$t.exr"
mv -f -- "$t.exr" "$out"
