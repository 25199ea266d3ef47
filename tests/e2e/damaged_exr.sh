#!/bin/bash
# siproject on every file of OpenEXR's damaged-image corpus (tests/data/damaged),
# each copied to a name ending in .exr: each run must end within 20 s (a hard
# kill otherwise, counted as a failure) in 1 GB of address space (ulimit -v),
# with either an image (exit 0, every sample finite) or a clear error (exit 3,
# the message naming the file, not an allocation failure, no output left).
# Never a signal, never another status.
set -u
SIPROJECT=$1
DATA=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0 images=0 refused=0 total=0
for f in "$DATA"/*; do
  name=$(basename "$f")
  [ "$name" = README.md ] && continue
  total=$((total + 1))
  in="$work/$name.exr" out="$work/out/$name.exr"
  mkdir -p "$work/out"
  cp "$f" "$in"
  ( ulimit -v 1048576; exec timeout -s KILL 20 "$SIPROJECT" "$in" -o "$out" --factor 2 --threads 2 -q ) \
    > "$work/log" 2>&1
  rc=$?
  msg=$(head -c 600 "$work/log")
  fail() { echo "FAIL $name: $1 (exit $rc): $msg"; failures=$((failures + 1)); }
  case $rc in
    0)
      stats=$(oiiotool --stats "$out" 2>&1)
      if ! echo "$stats" | grep -q "NanCount: \(0 \)*$" || ! echo "$stats" | grep -q "InfCount: \(0 \)*$"; then
        fail "an image with non-finite samples"
      else
        images=$((images + 1))
      fi ;;
    3)
      if ! grep -qF "$in" "$work/log"; then fail "the message does not name the file"
      elif sed "s|$in||g" "$work/log" | grep -qiE "bad_alloc|allocat|out of memory"; then
        fail "an allocation failure"
      elif [ -e "$out" ]; then fail "an output left"
      else refused=$((refused + 1)); fi ;;
    137) fail "killed (20 s or memory)" ;;
    *) fail "neither an image nor an input error" ;;
  esac
  leftover=$(find "$work/out" -mindepth 1 ! -name "$name.exr" | head -1)
  [ -n "$leftover" ] && fail "a temporary file left: $leftover"
  rm -rf "$work/out" "$in"
done
echo "$total files: $images images, $refused refused, $failures failures"
[ "$total" -ge 185 ] || { echo "FAIL: expected the 185 files of the corpus"; exit 1; }
[ "$failures" -eq 0 ]
