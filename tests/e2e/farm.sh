#!/usr/bin/env bash
# farm.sh SOURCE_DIR SIPROJECT SIMETRICS
#
# make TILES=4 FARM=slurm through a real one-node Slurm cluster (ctest label
# farm): scripts/farm/cluster.sh starts munged, slurmctld and slurmd in a
# temporary folder; the checker scene (48 x 200 at factor 4: a 192 x 800
# render, four bands of whole engine bands) rendered as 4 band jobs and a
# merge job gives the images (me-cubic-2x2, EXR and PNG: the pixels and
# metadata) of make's local single render,
# bit for bit (all but DateTime and sis:input, which names the inputs); a
# broken scene fails make naming the failed band's log with POV-Ray's
# message, leaving no result and no job; the cluster is stopped, and no
# daemon of it, no job's temporary folder and no cluster folder is left.
# The cluster is stopped on failure and on signals too. Needs root and
# Slurm (scripts/setup.sh installs it); otherwise skipped (exit 77).
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: ${0##*/} SOURCE_DIR SIPROJECT SIMETRICS" >&2; exit 64; }
src=$1 siproject=$2 simetrics=$3
unset MAKEFLAGS MFLAGS MAKELEVEL GNUMAKEFLAGS SLURM_CONF
fail() { echo "FAIL: $*" >&2; exit 1; }
start=$(date +%s.%N)
elapsed() { echo "$(date +%s.%N) $start" | awk '{ printf "%.1f s", $1 - $2 }'; }
[ "$(id -u)" -eq 0 ] || { echo "skipped: the one-node cluster runs its daemons as root"; exit 77; }
for c in munged slurmctld slurmd sbatch; do
  command -v "$c" >/dev/null || { echo "skipped: $c not installed (scripts/setup.sh)"; exit 77; }
done

tmp=$(mktemp -d "${TMPDIR:-/tmp}/sis-farm.XXXXXX")
cluster=
cleanup() {
  [ -z "$cluster" ] || bash "$src/scripts/farm/cluster.sh" stop "$cluster" || true
  rm -rf -- "$tmp"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
mkdir "$tmp/t"
export TMPDIR=$tmp/t   # the cluster's folder and every job's temporary folder

cluster=$(bash "$src/scripts/farm/cluster.sh" start --cpus 4) || fail "the cluster did not start"
eval "$(bash "$src/scripts/farm/cluster.sh" env "$cluster")"
daemons=$(cat "$cluster/slurmd.pid" "$cluster/slurmctld.pid" "$cluster/munge/munged.pid")
echo "ok: one-node cluster up in $cluster (pids $(echo $daemons)) at $(elapsed)"

# The images alone (make's targets), not the summary and page.
methods=me-cubic-2x2
mk() {  # mk LOG OUT SCENE ARGS...
  local log=$1 out=$2 scene=$3; shift 3
  make -C "$src" --no-print-directory SIPROJECT="$siproject" SIMETRICS="$simetrics" \
    RES=48x200 FACTOR=4 METHODS="$methods" OUT="$out" SCENE="$scene" "$@" \
    $(for m in $methods; do echo "$out/$scene/$m.exr"; done) >"$log" 2>&1
}
mk "$tmp/local.log" "$tmp/local" checker ||
  { cat "$tmp/local.log" >&2; fail "make (local, one render)"; }
echo "ok: local render and image at $(elapsed)"
mk "$tmp/farm.log" "$tmp/farm" checker TILES=4 FARM=slurm ||
  { cat "$tmp/farm.log" >&2; fail "make TILES=4 FARM=slurm"; }
grep -q '^farm: .*band jobs [0-9]* (array of 4), merge job [0-9]*' "$tmp/farm.log" ||
  { cat "$tmp/farm.log" >&2; fail "make FARM=slurm did not name its jobs"; }
partials=$(ls "$tmp/farm/farm/checker-48x200-f4-tiles4/"*-band*of4.exr | wc -l)
[ "$partials" -eq 4 ] || fail "expected 4 partials, found $partials"
[ ! -e "$tmp/farm/render/checker-48x200-f4.exr" ] && ! ls "$tmp/farm/render/"*band* >/dev/null 2>&1 ||
  fail "a render travelled: only the partials should leave the nodes"
for i in 0 1 2 3; do
  grep -q "^band $i of 4 on " "$tmp/farm/farm/checker-48x200-f4-tiles4/logs/band-$i.log" ||
    fail "no log of band $i"
done
meta() { oiiotool --info -v "$1" | sed 1,2d | grep -v -E '^ *(DateTime|sis:input):'; }
for m in $methods; do
  for e in exr png; do
    a=$tmp/local/checker/$m.$e b=$tmp/farm/checker/$m.$e
    oiiotool "$a" "$b" --fail 0 --warn 0 --diff >"$tmp/diff" 2>&1 || { cat "$tmp/diff" >&2; fail "$m.$e: the farm's pixels differ"; }
    cmp -s <(meta "$a") <(meta "$b") || { diff <(meta "$a") <(meta "$b") >&2; fail "$m.$e: the farm's metadata differ"; }
  done
  echo "ok: $m from 4 band jobs and a merge job equals the single local render's, bit for bit, at $(elapsed)"
done

mkdir "$tmp/scenes"
printf 'camera { location <0, 1, -3> look_at 0 }\nsphere { 0, 1 pigment { color Undeclared } }\n' >"$tmp/scenes/broken.pov"
if mk "$tmp/broken.log" "$tmp/farm" broken SCENEDIR="$tmp/scenes" TILES=4 FARM=slurm; then
  cat "$tmp/broken.log" >&2; fail "a broken scene: make succeeded"
fi
logs=$tmp/farm/farm/broken-48x200-f4-tiles4/logs
grep -q "band [0-3] of 4 failed (job [0-9_]*): see $logs/band-[0-3].log" "$tmp/broken.log" ||
  { cat "$tmp/broken.log" >&2; fail "a broken scene: no failed band named with its log"; }
grep -q "Parse Error" "$tmp/broken.log" ||
  { cat "$tmp/broken.log" >&2; fail "a broken scene: POV-Ray's message not shown"; }
left=$(find "$tmp/farm/broken" "$tmp/farm/farm/broken-48x200-f4-tiles4" -name '*.exr' -o -name '*.png' -o -name '*.tmp*' | head -3)
[ -z "$left" ] || fail "a broken scene left $left"
[ -z "$(squeue -h -o %A)" ] || fail "a broken scene left jobs: $(squeue -h)"
echo "ok: a broken scene fails make at $(elapsed): $(grep -m1 'failed (job' "$tmp/broken.log")"

bash "$src/scripts/farm/cluster.sh" stop "$cluster" || fail "the cluster did not stop"
stopped=$cluster cluster=
for p in $daemons; do
  ! kill -0 "$p" 2>/dev/null || fail "daemon $p still running after the stop"
done
[ ! -e "$stopped" ] || fail "$stopped left after the stop"
[ -z "$(ls -A "$tmp/t")" ] || fail "temporary files left: $(ls -A "$tmp/t")"
echo "ok: cluster stopped, no daemon, job folder or cluster folder left, at $(elapsed)"
