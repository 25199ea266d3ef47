#!/usr/bin/env bash
# band.sh --scene SCENE.pov --render WxH --cuts "Y0 Y1 ... H" --partials DIR
#         --siproject PATH [--povopts "OPTS"] [--band I] METHOD=OPTS...
#
# One band job of the farm (make FARM=slurm; sbatch --array runs one per
# band): band I (default: $SLURM_ARRAY_TASK_ID) renders rows [Y_I, Y_I+1) of
# the W x H render on this node, into a temporary folder of its own
# (${TMPDIR:-/tmp}), and writes for each METHOD the engine's partial of
# those rows, DIR/METHOD-bandIofK.exr (siproject --partial with the
# method's projection options OPTS); the band render is removed, only the
# partials leave the node. Cores: $SLURM_CPUS_PER_TASK (sbatch
# --cpus-per-task), else all of them, for POV-Ray (+WT) and siproject
# (--threads). On any failure or signal nothing of this band is left but
# the partials already whole; the exit status is the failing tool's.
set -euo pipefail
prog=${0##*/}
usage() { echo "usage: $prog --scene SCENE.pov --render WxH --cuts \"Y0 ... H\" --partials DIR --siproject PATH [--povopts OPTS] [--band I] METHOD=OPTS..." >&2; exit 64; }
scene= render= cuts= partials= siproject= povopts= band=${SLURM_ARRAY_TASK_ID:-}
while [ $# -gt 0 ]; do
  case $1 in
    --scene) scene=${2-}; shift 2 || usage ;;
    --render) render=${2-}; shift 2 || usage ;;
    --cuts) cuts=${2-}; shift 2 || usage ;;
    --partials) partials=${2-}; shift 2 || usage ;;
    --siproject) siproject=${2-}; shift 2 || usage ;;
    --povopts) povopts=${2-}; shift 2 || usage ;;
    --band) band=${2-}; shift 2 || usage ;;
    --*) usage ;;
    *) break ;;
  esac
done
[ -n "$scene" ] && [ -n "$render" ] && [ -n "$cuts" ] && [ -n "$partials" ] && [ -n "$siproject" ] && [ $# -ge 1 ] || usage
[[ $band =~ ^[0-9]+$ ]] || { echo "$prog: no band: give --band I or run as a task of sbatch --array" >&2; exit 64; }
read -r -a y <<<"$cuts"
tiles=$(( ${#y[@]} - 1 ))
[ "$band" -lt "$tiles" ] || { echo "$prog: band $band of $tiles: no such band (cuts: $cuts)" >&2; exit 64; }
width=${render%x*} height=${render#*x}
y0=${y[$band]} y1=${y[$((band + 1))]}
cores=${SLURM_CPUS_PER_TASK:-$(nproc)}
read -r -a pov <<<"$povopts"

work=$(mktemp -d "${TMPDIR:-/tmp}/sis-band.XXXXXX")
trap 'rm -rf -- "$work"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
echo "band $band of $tiles on $(hostname -s), $cores cores: rows $y0 to $((y1 - 1)) of $width x $height"
bash scripts/render_band.sh "$scene" "$work/band.exr" "$width" "$height" "$y0" "$y1" "${pov[@]}" +WT"$cores"
mkdir -p -- "$partials"
for spec in "$@"; do
  method=${spec%%=*}
  read -r -a opts <<<"${spec#*=}"
  "$siproject" "$work/band.exr" --partial -o "$partials/$method-band${band}of$tiles.exr" "${opts[@]}" --threads "$cores" -q
  echo "partial $partials/$method-band${band}of$tiles.exr"
done
