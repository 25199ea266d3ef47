#!/usr/bin/env bash
# merge.sh --partials DIR --tiles K --out DIR --siproject PATH METHOD=OPTS...
#
# The farm's merge job (make FARM=slurm; run after every band job ended
# well): for each METHOD, siproject --merge adds the partials
# DIR/METHOD-band{0..K-1}ofK.exr and forms the final images as make's local
# pipeline does, OUT/METHOD.exr (float, siproject -v's stage times in
# OUT/METHOD.log) and OUT/METHOD.png (8-bit sRGB), with the display options
# OPTS. Written to temporary names, renamed once all three are whole; on a
# failure siproject's message is shown and nothing of that method is left.
# Threads: $SLURM_CPUS_PER_TASK, else all cores.
set -euo pipefail
prog=${0##*/}
usage() { echo "usage: $prog --partials DIR --tiles K --out DIR --siproject PATH METHOD=OPTS..." >&2; exit 64; }
partials= tiles= out= siproject=
while [ $# -gt 0 ]; do
  case $1 in
    --partials) partials=${2-}; shift 2 || usage ;;
    --tiles) tiles=${2-}; shift 2 || usage ;;
    --out) out=${2-}; shift 2 || usage ;;
    --siproject) siproject=${2-}; shift 2 || usage ;;
    --*) usage ;;
    *) break ;;
  esac
done
[ -n "$partials" ] && [[ $tiles =~ ^[1-9][0-9]*$ ]] && [ -n "$out" ] && [ -n "$siproject" ] && [ $# -ge 1 ] || usage
cores=${SLURM_CPUS_PER_TASK:-$(nproc)}
t=
trap '[ -z "$t" ] || rm -f -- "$t.exr" "$t.png" "$t.log"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
mkdir -p -- "$out"
echo "merge on $(hostname -s), $cores cores: $tiles bands"
for spec in "$@"; do
  method=${spec%%=*}
  read -r -a opts <<<"${spec#*=}"
  inputs=()
  for ((i = 0; i < tiles; i++)); do inputs+=("$partials/$method-band${i}of$tiles.exr"); done
  t=$out/.$method.tmp$$
  if ! "$siproject" --merge "${inputs[@]}" -o "$t.exr" -d float "${opts[@]}" --threads "$cores" -v 2>"$t.log"; then
    cat "$t.log" >&2
    echo "$prog: siproject --merge failed for $method" >&2
    exit 1
  fi
  "$siproject" --merge "${inputs[@]}" -o "$t.png" "${opts[@]}" --threads "$cores" -q
  mv -f -- "$t.exr" "$out/$method.exr" && mv -f -- "$t.png" "$out/$method.png" && mv -f -- "$t.log" "$out/$method.log"
  t=
  printf 'project  %-13s %s s\n' "$method" "$(sed -n 's/.*total \([0-9.]*\) s.*/\1/p' "$out/$method.log")"
done
