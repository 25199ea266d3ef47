#!/usr/bin/env bash
# Writes the golden outputs of cases.txt here with the siproject given:
#   tests/golden/make.sh build/tools/siproject
# Run only to pin a deliberate change of results; the test compares against
# what this wrote.
set -euo pipefail
siproject=$(realpath "$1")
here=$(cd "$(dirname "$0")" && pwd)
cd "$here"
while IFS='|' read -r name inputs options; do
  name=${name//[[:space:]]/}
  [ -z "$name" ] || [ "${name:0:1}" = "#" ] && continue
  ins=()
  for i in $inputs; do
    if [ "${i:0:1}" = "@" ]; then ins+=("${i:1}.coeffs.exr"); else ins+=("$i"); fi
  done
  ext=exr; [ "${name%-png}" != "$name" ] && ext=png
  read -r -a opts <<< "${options//OUT\//}"
  "$siproject" "${ins[@]}" -o "$name.$ext" "${opts[@]}" -q
done < cases.txt
