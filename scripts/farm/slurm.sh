#!/usr/bin/env bash
# slurm.sh --name NAME --tiles K --methods "M..." --partials DIR --logs DIR
#          --outputs "FILE..." [--cpus N] [--slurm-args "ARGS"] [--submit-only]
#          BAND_ARGS... --merge MERGE_ARGS...
#
# make FARM=slurm's driver: submits an sbatch job array of K band jobs
# (scripts/farm/band.sh BAND_ARGS, task I writes DIR/M-bandIofK.exr for each
# method M) and a merge job that runs once every band ended well
# (scripts/farm/merge.sh MERGE_ARGS: --dependency=afterok, killed if a band
# fails), logs LOGS/band-I.log and LOGS/merge.log, N cores a task
# (--cpus-per-task, default 1), SLURM_ARGS last (partition, account, time...:
# they override these). Prints the two job ids, then waits for the merge
# (sbatch --wait) and checks the files, not only the status (sbatch --wait
# exits 0 for a job that never ran): a band without its partials fails,
# naming its log and showing its end, the rest of the array is cancelled; a
# merge without the OUTPUTS fails likewise. With --submit-only it prints the
# ids and returns. Old partials, logs and OUTPUTS are removed first. On INT or
# TERM the jobs are cancelled.
set -euo pipefail
prog=${0##*/}
usage() { echo "usage: $prog --name NAME --tiles K --methods \"M...\" --partials DIR --logs DIR --outputs \"FILE...\" [--cpus N] [--slurm-args ARGS] [--submit-only] BAND_ARGS... --merge MERGE_ARGS..." >&2; exit 64; }
name= tiles= methods= partials= logs= outputs= cpus=1 slurm_args= submit_only=
while [ $# -gt 0 ]; do
  case $1 in
    --name) name=${2-}; shift 2 || usage ;;
    --tiles) tiles=${2-}; shift 2 || usage ;;
    --methods) methods=${2-}; shift 2 || usage ;;
    --partials) partials=${2-}; shift 2 || usage ;;
    --logs) logs=${2-}; shift 2 || usage ;;
    --outputs) outputs=${2-}; shift 2 || usage ;;
    --cpus) cpus=${2-}; shift 2 || usage ;;
    --slurm-args) slurm_args=${2-}; shift 2 || usage ;;
    --submit-only) submit_only=1; shift ;;
    *) break ;;
  esac
done
band_args=()
while [ $# -gt 0 ] && [ "$1" != --merge ]; do band_args+=("$1"); shift; done
[ $# -ge 2 ] || usage
shift
merge_args=("$@")
[ -n "$name" ] && [[ $tiles =~ ^[1-9][0-9]*$ ]] && [ -n "$methods" ] && [ -n "$partials" ] && [ -n "$logs" ] && [ -n "$outputs" ] || usage
[[ $cpus =~ ^[1-9][0-9]*$ ]] || { echo "$prog: FARM_CPUS=$cpus: expected a positive whole number" >&2; exit 64; }
command -v sbatch >/dev/null || { echo "$prog: sbatch not found: FARM=slurm needs Slurm's client commands (scripts/setup.sh installs them)" >&2; exit 127; }
read -r -a extra <<<"$slurm_args"
read -r -a method_list <<<"$methods"
read -r -a output_list <<<"$outputs"

partial_of() { echo "$partials/$1-band$2of$tiles.exr"; }
for ((i = 0; i < tiles; i++)); do
  for m in "${method_list[@]}"; do rm -f -- "$(partial_of "$m" "$i")"; done
  rm -f -- "$logs/band-$i.log"
done
rm -f -- "$logs/merge.log" "${output_list[@]}"
mkdir -p -- "$partials" "$logs"

bands= merge= waiter= out=$logs/.sbatch$$
cancel() { local j; j=$(echo $bands $merge); [ -z "$j" ] || scancel $j 2>/dev/null || true; }
cleanup() { [ -z "$waiter" ] || kill "$waiter" 2>/dev/null || true; rm -f -- "$out" "$out.err"; }
trap cleanup EXIT
trap 'cancel; echo "$prog: interrupted: jobs $bands $merge cancelled" >&2; exit 130' INT
trap 'cancel; echo "$prog: terminated: jobs $bands $merge cancelled" >&2; exit 143' TERM

common=(--parsable --chdir="$PWD" --cpus-per-task="$cpus")
if ! bands=$(sbatch "${common[@]}" --job-name="sis-band-$name" --array=0-$((tiles - 1)) \
    --output="$logs/band-%a.log" "${extra[@]}" scripts/farm/band.sh "${band_args[@]}" 2>"$out.err"); then
  cat "$out.err" >&2; echo "$prog: sbatch could not submit the band jobs (SLURM_ARGS='$slurm_args')" >&2; bands=; exit 1
fi
bands=${bands%%;*}
merge_cmd=(sbatch "${common[@]}" --job-name="sis-merge-$name" --dependency=afterok:"$bands" --kill-on-invalid-dep=yes
  --output="$logs/merge.log" "${extra[@]}")
if [ -n "$submit_only" ]; then
  if ! merge=$("${merge_cmd[@]}" scripts/farm/merge.sh "${merge_args[@]}" 2>"$out.err"); then
    cat "$out.err" >&2; cancel; echo "$prog: sbatch could not submit the merge job" >&2; exit 1
  fi
  merge=${merge%%;*}
  echo "farm: submitted $name: band jobs $bands (array of $tiles), merge job $merge (after them); logs in $logs"
  bands= merge=
  exit 0
fi
"${merge_cmd[@]}" --wait scripts/farm/merge.sh "${merge_args[@]}" >"$out" 2>"$out.err" &
waiter=$!
for _ in $(seq 300); do
  [ -s "$out" ] && break
  kill -0 "$waiter" 2>/dev/null || break
  sleep 0.1
done
merge=$(head -n 1 "$out" 2>/dev/null || true)
merge=${merge%%;*}
if [ -z "$merge" ]; then
  cat "$out.err" >&2; cancel; echo "$prog: sbatch could not submit the merge job" >&2; exit 1
fi
echo "farm: $name: band jobs $bands (array of $tiles), merge job $merge; logs in $logs"
rc=0
wait "$waiter" || rc=$?
waiter=

# Each band's partials, all of them, or the band failed; once one failed the
# rest are cancelled and their end awaited, so the logs say which failed.
incomplete() {
  local i m
  for ((i = 0; i < tiles; i++)); do
    for m in "${method_list[@]}"; do
      [ -s "$(partial_of "$m" "$i")" ] || { echo "$i"; break; }
    done
  done
}
if [ -n "$(incomplete)" ]; then
  cancel
  for _ in $(seq 300); do
    [ -z "$(squeue -h -j "$bands" -o %i 2>/dev/null)" ] && break
    sleep 0.1
  done
  failed=() cancelled=()
  for i in $(incomplete); do
    if grep -q 'CANCELLED' "$logs/band-$i.log" 2>/dev/null; then cancelled+=("$i"); else failed+=("$i"); fi
  done
  if [ ${#failed[@]} -gt 0 ]; then
    log=$logs/band-${failed[0]}.log
    if [ -s "$log" ]; then echo "--- $log (last lines)" >&2; tail -n 12 "$log" >&2
    else echo "--- $log: missing or empty (the job did not start)" >&2; fi
  fi
  [ ${#cancelled[@]} -eq 0 ] || echo "$prog: band(s) ${cancelled[*]} of $tiles cancelled after a failure" >&2
  for i in "${failed[@]}"; do echo "$prog: band $i of $tiles failed (job ${bands}_$i): see $logs/band-$i.log" >&2; done
  exit 1
fi
missing=()
for f in "${output_list[@]}"; do [ -s "$f" ] || missing+=("$f"); done
if [ ${#missing[@]} -gt 0 ] || [ "$rc" -ne 0 ]; then
  [ -s "$logs/merge.log" ] && { echo "--- $logs/merge.log (last lines)" >&2; tail -n 12 "$logs/merge.log" >&2; }
  cat "$out.err" >&2
  echo "$prog: the merge job $merge failed (sbatch status $rc${missing:+, ${#missing[@]} results missing}): see $logs/merge.log" >&2
  exit 1
fi
grep '^project ' "$logs/merge.log" || true
