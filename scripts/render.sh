#!/usr/bin/env bash
# render.sh SCENE.pov OUT.exr WIDTH HEIGHT [extra povray options...]
#
# Renders SCENE.pov with POV-Ray 3.7 to OUT.exr (OpenEXR, half float, linear),
# WIDTH x HEIGHT pixels, antialiasing off: one ray through each pixel centre
# (docs/design.md sections 2 and 9). Settings come from scenes/povray.ini (through
# POVINI); extra options are passed last and override them, e.g.
#   scripts/render.sh scenes/zoneplate.pov out/zp.exr 256 256 Declare=ZP_K=201.06
# RENDER_MESH_CAMERA=1: SCENE.pov is a mesh band of sirays mesh; its two
# expected warnings are not shown.
# RENDER_STATS=FILE: also writes FILE, lines of "NAME VALUE": wall_s (POV-Ray's
# wall time, start-up and parse included), wall_runs, parse_s, trace_s
# (POV-Ray's own times), pixels and samples (its primary rays: one per pixel
# with antialiasing off, plus the supersamples of +A); POV-Ray's statistics
# (+GS) are read for it and not shown. RENDER_REPEATS=N (default 1): a render
# under 3 s is timed up to N times (the repeats to a discarded file), stopping
# once two runs agree within 5 %; wall_s is the smallest.
#
# Quiet on success (only scene warnings and #debug output, on stderr).
# POV-Ray writes to a temporary name in OUT's folder, renamed to OUT only on
# success. On failure POV-Ray's own messages go to stderr, the partial output
# is removed and the script exits with POV-Ray's exit status (1 error,
# 2 user abort). Usage errors exit with 64.
#
# The Debian build warns on every run when ~/.povray/3.7/povray.conf is
# missing. POV-Ray finds that file through $HOME, so POV-Ray alone runs with
# HOME set to a private temporary folder holding a povray.conf: a copy of
# /etc/povray/3.7/povray.conf plus [Permitted Paths] for the scene's folder,
# the project's scenes/ and OUT's folder. The user's real home is never read
# or written; the folder is removed on exit.
set -euo pipefail

prog=${0##*/}
usage() {
  echo "usage: $prog SCENE.pov OUT.exr WIDTH HEIGHT [extra povray options...]" >&2
  exit 64
}
[ $# -ge 4 ] || usage
scene=$1 out=$2 width=$3 height=$4
shift 4
[[ $width =~ ^[1-9][0-9]*$ && $height =~ ^[1-9][0-9]*$ ]] ||
  { echo "$prog: WIDTH and HEIGHT must be positive integers: '$width' '$height'" >&2; exit 64; }
[ -f "$scene" ] && [ -r "$scene" ] || { echo "$prog: cannot read scene '$scene'" >&2; exit 64; }
[[ $out == *.exr ]] || { echo "$prog: output must end in .exr: '$out'" >&2; exit 64; }
command -v povray >/dev/null ||
  { echo "$prog: povray not found (run scripts/setup.sh)" >&2; exit 127; }

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd -P)
project_scenes=$(cd "$here/../scenes" && pwd -P)
ini=$project_scenes/povray.ini
[ -r "$ini" ] || { echo "$prog: missing $ini" >&2; exit 64; }

scene=$(realpath -e -- "$scene")
scene_dir=$(dirname -- "$scene")
mkdir -p -- "$(dirname -- "$out")"
out=$(realpath -m -- "$out")
out_dir=$(dirname -- "$out")
# POV-Ray splits option values at blanks unless they are in double quotes, so
# paths are passed quoted; a double quote inside a path cannot be passed.
case "$scene$out" in
  *'"'*) echo "$prog: paths must not contain a double quote" >&2; exit 64 ;;
esac

# Image buffer: 20 bytes a pixel; keep the whole frame in memory (no spill file).
mi=$(( (width * height * 20 + 1048575) / 1048576 + 64 ))

work=$(mktemp -d "${TMPDIR:-/tmp}/render-povray.XXXXXX")
tmp=
spare=
stats_tmp=
pid=
cleanup() {
  [ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
  [ -n "$tmp" ] && rm -f -- "$tmp" "${tmp%.exr}.pov-state"
  [ -n "$spare" ] && rm -f -- "$spare" "${spare%.exr}.pov-state"
  [ -n "$stats_tmp" ] && rm -f -- "$stats_tmp"
  rm -rf -- "$work"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# Private home with a user povray.conf. User paths replace the system ones, so
# the conf is the system conf plus the folders this render needs.
conf_dir=$work/home/.povray/3.7
mkdir -p -- "$conf_dir"
{
  if [ -r /etc/povray/3.7/povray.conf ]; then
    cat /etc/povray/3.7/povray.conf
  else
    printf '[File I/O Security]\nrestricted\n[Shellout Security]\nforbidden\n'
  fi
  printf '\n; added by %s\n[Permitted Paths]\n' "$prog"
  printf 'read* = "%s"\n' "$scene_dir" "$project_scenes"
  printf 'read+write = "%s"\n' "$out_dir"
} > "$conf_dir/povray.conf"

tmp=$(mktemp --suffix=.exr -- "$out_dir/.${out##*/}.XXXXXX")
log=$work/povray.log

# Strip the start-up banner (the Unix front end prints it whatever the stream
# settings) and the section markers; what remains is warnings, #debug output
# and errors. With RENDER_MESH_CAMERA=1 (a band of sirays mesh, which
# includes the scene and replaces its camera by a mesh camera) also the two
# warnings every such band gets: more than one camera, and the mesh camera
# being an experimental feature.
filter_log() {
  awk '
    /^Persistence of Vision\(tm\) Ray Tracer Version/ { banner = 1 }
    banner && /^Support libraries used by POV-Ray:/ { libs = 1 }
    banner && libs && /^$/ { banner = 0; libs = 0; next }
    banner { next }
    # +GS (RENDER_STATS): the statistics blocks, each a rule of dashes and
    # its title up to the next section marker, are read into the stats file.
    rule { rule = 0; if ($0 ~ /^(Parser|Render) Statistics$/) { skip = 1; next } print held }
    /^-+$/ && !skip && stats { rule = 1; held = $0; next }
    /^==== \[[A-Za-z ]+\.\.\.\] =+$/ { skip = 0; next }
    /^POV-Ray finished$/ { skip = 0; next }
    skip { next }
    { print }
    END { if (rule) print held }
  ' stats="${stats:+1}" "$log" | sed -e '/./,$!d' | if [ "${RENDER_MESH_CAMERA:-0}" = 1 ]; then
    # POV-Ray wraps a message at 80 columns, its continuation lines indented:
    # each message is taken whole, and the two expected ones dropped.
    awk '
      function flush() {
        m = msg
        gsub(/\n /, " ", m)
        if (m ~ /[^ \n]/ && m !~ /More than one camera/ && m !~ /experimental feature\(s\): mesh/)
          printf "%s", msg
        msg = ""
      }
      { sub(/.*\r/, "") }  # a progress line ended by a carriage return
      /^ / && msg != "" { msg = msg $0 "\n"; next }
      { flush(); msg = $0 "\n" }
      END { flush() }
    '
  else cat; fi
}

# A mesh band is named by its file name alone, from its folder, so that
# POV-Ray's messages about it wrap between words.
input=$scene run_dir=$PWD
if [ "${RENDER_MESH_CAMERA:-0}" = 1 ]; then input=${scene##*/} run_dir=$scene_dir; fi
options=("$@")
stats=${RENDER_STATS:-}
repeats=${RENDER_REPEATS:-1}
[[ $repeats =~ ^[1-9][0-9]*$ ]] ||
  { echo "$prog: RENDER_REPEATS must be a positive whole number: '$repeats'" >&2; exit 64; }
gs=()
[ -n "$stats" ] && gs=(+GS)
# povray TARGET: one run, its messages in $log, its wall time in $wall.
povray_run() {
  local t0 t1
  t0=$(date +%s.%N)
  set +e
  ( cd -- "$run_dir" && HOME=$work/home POVINI=$ini exec povray \
    +I"\"$input\"" +O"\"$1\"" +W"$width" +H"$height" \
    -A +FE -D -P +MI"$mi" +L"\"$scene_dir\"" \
    "${options[@]}" "${gs[@]}" ) >"$log" 2>&1 </dev/null &
  pid=$!
  wait "$pid"
  rc=$?
  pid=
  set -e
  t1=$(date +%s.%N)
  wall=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')
}

povray_run "$tmp"
if [ "$rc" -ne 0 ]; then
  filter_log >&2
  echo "$prog: povray failed with status $rc rendering $scene" >&2
  exit "$rc"
fi
if [ ! -s "$tmp" ]; then
  filter_log >&2
  echo "$prog: povray reported success but wrote no image for $scene" >&2
  exit 1
fi
filter_log >&2
if [ -n "$stats" ]; then
  # POV-Ray's statistics of the first run, then the repeats' wall times.
  walls=$wall
  stats_text=$(awk -v wall="$wall" '
    /^Pixels:/ { pixels = $2; samples = $4 }
    /^  Parse Time:/ { match($0, /\(([0-9.]+) seconds\)/); parse = substr($0, RSTART + 1, RLENGTH - 10) }
    /^  Trace Time:/ { match($0, /\(([0-9.]+) seconds\)/); trace = substr($0, RSTART + 1, RLENGTH - 10) }
    END { printf "parse_s %s\ntrace_s %s\npixels %s\nsamples %s\n", parse, trace, pixels, samples }
  ' "$log")
  again=$(mktemp --suffix=.exr -- "$out_dir/.${out##*/}.repeat.XXXXXX")
  spare=$again
  for (( k = 1; k < repeats; k++ )); do
    last=${walls##* }
    awk -v w="$last" 'BEGIN { exit !(w < 3) }' || break
    povray_run "$again"
    rm -f -- "$again"
    [ "$rc" -eq 0 ] || { filter_log >&2; echo "$prog: povray failed with status $rc timing $scene again" >&2; exit "$rc"; }
    walls="$walls $wall"
    # two runs within 5 % of each other: a third would not move the smallest much
    awk -v a="$last" -v b="$wall" 'BEGIN { d = a - b; if (d < 0) d = -d; m = a < b ? a : b; exit !(d <= 0.05 * m) }' && break
  done
  rm -f -- "$spare"
  spare=
  stats_tmp=$(mktemp -- "$(dirname -- "$(realpath -m -- "$stats")")/.${stats##*/}.XXXXXX")
  {
    printf 'wall_s %s\n' "$(printf '%s\n' $walls | sort -g | head -n 1)"
    printf 'wall_runs %s\n' "$walls"
    printf '%s\n' "$stats_text"
  } > "$stats_tmp"
  chmod "$(printf '%o' $(( 0666 & ~0$(umask) )))" -- "$stats_tmp"
  mv -f -- "$stats_tmp" "$stats"
  stats_tmp=
fi
chmod "$(printf '%o' $(( 0666 & ~0$(umask) )))" -- "$tmp"  # mktemp makes 0600
mv -f -- "$tmp" "$out"
tmp=
