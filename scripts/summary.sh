#!/usr/bin/env bash
# summary.sh --dir DIR --render RENDER.exr [--sizes "W H RW RH"] [--simetrics PATH]
#            [--cutoffs "C ..."] METHOD...
#
# Writes DIR/summary.txt (a table for people) and DIR/summary.csv (for
# programs) from the results the Makefile leaves in DIR, one row per METHOD
# (output W x H formed from RENDER, RW x RH; the sizes only label the table):
#   time   siproject's own "total" from DIR/METHOD.log (siproject -v: read,
#          acquisition, prefilter, resampling and writing the EXR), seconds;
#   hp_C   high-pass energy share of DIR/METHOD.exr above cutoff C in
#          cycles/pixel (docs/design.md section 8), from `simetrics IMAGE --json
#          --cutoff C ...` (its "hp_C" keys). In the table as a percentage,
#          in the CSV as the fraction simetrics prints.
# Without simetrics (not built yet) or when it fails, the high-pass columns
# say n/a (empty in the CSV) and the table says why; the summary is still
# written. Files are written to temporary names and renamed.
set -euo pipefail

prog=${0##*/}
usage() {
  echo "usage: $prog --dir DIR --render RENDER.exr [--sizes \"W H RW RH\"] [--simetrics PATH] [--cutoffs \"C ...\"] METHOD..." >&2
  exit 64
}
dir= render= sizes= simetrics= cutoffs="0.125 0.25"
while [ $# -gt 0 ]; do
  case $1 in
    --dir) dir=${2-}; shift 2 || usage ;;
    --render) render=${2-}; shift 2 || usage ;;
    --sizes) sizes=${2-}; shift 2 || usage ;;
    --simetrics) simetrics=${2-}; shift 2 || usage ;;
    --cutoffs) cutoffs=${2-}; shift 2 || usage ;;
    --) shift; break ;;
    -*) usage ;;
    *) break ;;
  esac
done
[ -n "$dir" ] && [ -n "$render" ] && [ $# -ge 1 ] || usage
read -r -a cuts <<<"$cutoffs"

metrics_note=
if [ -z "$simetrics" ] || [ ! -x "$simetrics" ]; then
  metrics_note="high-pass shares n/a: simetrics not found${simetrics:+ at $simetrics}"
  simetrics=
fi

txt=$(mktemp "$dir/.summary.txt.XXXXXX")
csv=$(mktemp "$dir/.summary.csv.XXXXXX")
trap 'rm -f -- "$txt" "$csv"' EXIT

scene=${dir%/}; scene=${scene##*/}
read -r w h rw rh <<<"$sizes" || true
header=$(printf '%-13s %9s' method "time (s)")
csv_header=method,time_s
for c in "${cuts[@]}"; do
  header+=$(printf ' %12s' "hp>$c (%)")
  csv_header+=,hp_$c
done
header+="  siproject"
echo "$csv_header" >"$csv"

rows=
failed=0
for m in "$@"; do
  log=$dir/$m.log exr=$dir/$m.exr
  time=$(sed -n 's/.*total \([0-9.]*\) s.*/\1/p' "$log" 2>/dev/null | tail -n 1)
  # siproject -v: "siproject: W x H x C -> W x H, min-error tent, display centred, boundary ..."
  what=$(sed -n 's/.*-> [0-9]* x [0-9]*, \(.*\), boundary.*/\1/p' "$log" 2>/dev/null | tail -n 1)
  json=
  if [ -n "$simetrics" ]; then
    cut_args=()
    for c in "${cuts[@]}"; do cut_args+=(--cutoff "$c"); done
    if ! json=$("$simetrics" "$exr" --json "${cut_args[@]}" 2>&1); then
      echo "$prog: simetrics failed on $exr: $json" >&2
      json= failed=1
    fi
  fi
  row=$(printf '%-13s %9s' "$m" "${time:-n/a}")
  csv_row=$m,$time
  for c in "${cuts[@]}"; do
    key="hp_$c"
    v=$(printf '%s\n' "$json" | tr ',{}' '\n\n\n' |
        sed -n "s/^[[:space:]]*\"${key//./\\.}\"[[:space:]]*:[[:space:]]*\([-+0-9.eE]*\).*/\1/p" | head -n 1)
    if [ -n "$v" ]; then
      row+=$(awk -v v="$v" 'BEGIN { printf " %12.2f", 100 * v }')
    else
      row+=$(printf ' %12s' n/a)
      [ -z "$json" ] || failed=1
    fi
    csv_row+=,$v
  done
  rows+="$row  ${what:-?}"$'\n'
  echo "$csv_row" >>"$csv"
done
if [ "$failed" -ne 0 ] && [ -z "$metrics_note" ]; then
  metrics_note="some high-pass shares n/a: simetrics failed or printed no hp_C key"
fi

{
  echo "$scene: output ${w:-?} x ${h:-?} from $render (${rw:-?} x ${rh:-?})"
  echo "$header"
  printf '%s' "$rows"
  echo "time: siproject's total (read, acquire, prefilter, resample, write EXR)."
  echo "hp>C: share of the EXR luminance's DFT energy above C cycles/pixel, mean removed."
  [ -z "$metrics_note" ] || echo "$metrics_note"
} >"$txt"

chmod "$(printf '%o' $(( 0666 & ~0$(umask) )))" -- "$txt" "$csv"  # mktemp makes 0600
mv -f -- "$txt" "$dir/summary.txt"
mv -f -- "$csv" "$dir/summary.csv"
trap - EXIT
