#!/usr/bin/env bash
# timed_make.sh FILE COMMAND...
#
# Runs COMMAND (a make that brings FILE up to date). When it made FILE anew,
# writes the command's wall time in seconds to .NAME.seconds beside FILE
# (NAME: FILE's name without its extension), written to a temporary name and
# renamed; when FILE was up to date, the file of its last making stays. The
# time is the whole render's: for a mesh render its bands' scenes written by
# sirays, POV-Ray's start-up, parse and trace, and the assembly; for a
# regular one POV-Ray's run; each with make's own start-up.
# Exits with COMMAND's status (64 on a usage error).
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: ${0##*/} FILE COMMAND..." >&2; exit 64; }
file=$1
shift
name=${file##*/}
side=$(dirname -- "$file")/.${name%.*}.seconds
before=$(stat -c %.9Y -- "$file" 2>/dev/null || true)
t0=$(date +%s.%N)
"$@"
t1=$(date +%s.%N)
after=$(stat -c %.9Y -- "$file" 2>/dev/null || true)
if [ -n "$after" ] && [ "$after" != "$before" ]; then
  awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f\n", b - a }' > "$side.tmp"
  mv -f -- "$side.tmp" "$side"
fi
