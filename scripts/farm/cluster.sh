#!/usr/bin/env bash
# cluster.sh start [--cpus N] [DIR] | stop DIR | env DIR
#
# A one-node Slurm cluster on this machine, everything in one folder: for the
# farm test and for trying FARM=slurm without a cluster. As root (munged,
# slurmctld and slurmd run as root), no systemd.
#
#   start [DIR]  make DIR (default: a new mktemp -d folder), write its munge
#                key and slurm.conf (two free TCP ports, this host as the one
#                node with all its CPUs), start munged, slurmctld and slurmd
#                with their sockets, state, spool, logs and pid files in DIR,
#                wait until the node is idle, and print DIR on stdout. With
#                --cpus N the node offers N CPUs whatever it has (Slurm's
#                config_overrides): the farm test's 4 band jobs, short and
#                waiting more than computing, then start at once. On any
#                failure the daemons started are stopped, DIR is removed and
#                the daemons' logs are shown.
#   stop DIR     cancel the cluster's jobs, stop its daemons (and any job step
#                of its left running) by their pids, remove DIR.
#   env DIR      print `export SLURM_CONF=DIR/slurm.conf`, for eval.
#
# Slurm's commands find the cluster through SLURM_CONF=DIR/slurm.conf.
set -euo pipefail
prog=${0##*/}
die() { echo "$prog: $*" >&2; exit 1; }
usage() { echo "usage: $prog start [--cpus N] [DIR] | stop DIR | env DIR" >&2; exit 64; }

for c in munged mungekey slurmctld slurmd sinfo scancel squeue; do
  command -v "$c" >/dev/null || die "$c not found: run scripts/setup.sh (make setup)"
done

# The pids of the cluster's daemons, from their pid files.
daemon_pids() {
  local f
  for f in "$1/slurmd.pid" "$1/slurmctld.pid" "$1/munge/munged.pid"; do
    [ -s "$f" ] && cat "$f"
  done
  return 0
}

# Job steps of this cluster's slurmd: slurmstepd processes with a file open
# in DIR (its spool).
step_pids() {
  local p
  for p in $(pgrep -x slurmstepd || true); do
    if ls -l "/proc/$p/fd" 2>/dev/null | grep -qF -- " $1/"; then echo "$p"; fi
  done
  return 0
}

# Sends TERM to PIDS, waits up to 10 s for them to end, then KILL.
end_pids() {
  [ $# -gt 0 ] || return 0
  kill -TERM "$@" 2>/dev/null || true
  local i p alive
  for i in $(seq 100); do
    alive=()
    for p in "$@"; do kill -0 "$p" 2>/dev/null && alive+=("$p"); done
    [ ${#alive[@]} -eq 0 ] && return 0
    sleep 0.1
  done
  kill -KILL "${alive[@]}" 2>/dev/null || true
}

stop() {
  local dir=$1
  [ -f "$dir/slurm.conf" ] || die "$dir is not a cluster folder (no slurm.conf)"
  if [ -s "$dir/slurmctld.pid" ] && kill -0 "$(cat "$dir/slurmctld.pid")" 2>/dev/null; then
    local jobs
    jobs=$(SLURM_CONF=$dir/slurm.conf squeue -h -o %A 2>/dev/null || true)
    [ -z "$jobs" ] || SLURM_CONF=$dir/slurm.conf scancel $jobs 2>/dev/null || true
  fi
  local pids
  pids=$(daemon_pids "$dir")
  # shellcheck disable=SC2046
  end_pids $(step_pids "$dir") $pids
  rm -rf -- "$dir"
}

free_ports() {  # two TCP ports free on this host now
  python3 -c '
import socket
ss = [socket.socket() for _ in range(2)]
for s in ss: s.bind(("127.0.0.1", 0))
print(*[s.getsockname()[1] for s in ss])'
}

start() {
  local cpus= overrides=
  if [ "${1:-}" = --cpus ]; then
    [[ ${2:-} =~ ^[1-9][0-9]*$ ]] || die "--cpus ${2:-}: expected a positive whole number"
    cpus=$2 overrides=1
    shift 2
  fi
  [ $# -le 1 ] || usage
  local dir=${1:-}
  if [ -z "$dir" ]; then dir=$(mktemp -d "${TMPDIR:-/tmp}/sis-slurm.XXXXXX")
  else mkdir -m 700 -- "$dir" || die "cannot make $dir (it must not exist)"; fi
  dir=$(cd "$dir" && pwd -P)
  trap 'rc=$?; if [ $rc -ne 0 ]; then show_logs "$dir"; stop "$dir"; fi' EXIT
  trap 'exit 130' INT
  trap 'exit 143' TERM
  [ "$(id -u)" -eq 0 ] || die "must run as root (munged, slurmctld and slurmd run as root here)"
  local host ports ctld_port slurmd_port
  host=$(hostname -s)
  cpus=${cpus:-$(nproc)}
  ports=$(free_ports)
  read -r ctld_port slurmd_port <<<"$ports"
  mkdir -p "$dir/munge" "$dir/state" "$dir/spool"
  chmod 700 "$dir/munge"
  mungekey --create --keyfile="$dir/munge/munge.key" 2>/dev/null ||
    die "mungekey could not write $dir/munge/munge.key"
  cat >"$dir/slurm.conf" <<EOF
# A one-node cluster made by scripts/farm/cluster.sh; everything in $dir.
ClusterName=sis
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
# The cgroup plugins start a node that shows idle but fails every job.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
# Jobs start at once and leave the queue soon (the defaults cost seconds).
SchedulerParameters=batch_sched_delay=0
MinJobAge=5
DependencyParameters=kill_invalid_depend
ReturnToService=2
${overrides:+SlurmdParameters=config_overrides
}AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=sis Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  munged --force --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.socket" \
    --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" \
    --seed-file="$dir/munge/munged.seed" || die "munged did not start"
  export SLURM_CONF=$dir/slurm.conf
  slurmctld -f "$SLURM_CONF" || die "slurmctld did not start"
  slurmd -f "$SLURM_CONF" -N "$host" || die "slurmd did not start"
  local i state=
  for i in $(seq 200); do
    state=$(sinfo -h -N -n "$host" -o %t 2>/dev/null || true)
    [ "$state" = idle ] && break
    sleep 0.1
  done
  [ "$state" = idle ] || die "node $host not idle after 20 s (state '${state:-none}')"
  trap - EXIT INT TERM
  echo "$dir"
}

show_logs() {
  local f
  for f in "$1/munge/munged.log" "$1/slurmctld.log" "$1/slurmd.log"; do
    [ -s "$f" ] && { echo "--- $f" >&2; tail -n 20 "$f" >&2; }
  done
  return 0
}

case ${1:-} in
  start) shift; start "$@" ;;
  stop) [ $# -eq 2 ] || usage; stop "$2" ;;
  env) [ $# -eq 2 ] || usage; [ -f "$2/slurm.conf" ] || die "$2 is not a cluster folder (no slurm.conf)"
       echo "export SLURM_CONF=$(cd "$2" && pwd -P)/slurm.conf" ;;
  *) usage ;;
esac
