#!/usr/bin/env bash
# Corpus test: every real program of the shared corpus goes through `check` and identity `convert`.
#
#   corpus_test.sh POSTPROC_BINARY CORPUS_DIR
#
# CORPUS_DIR/MANIFEST.tsv lists the files (columns: file source_repo source_path commit license
# dialect axes lines bytes notes). Dialect `other` is read as heidenhain-iso for the MillPlus file
# and as fanuc for the others; fanuc files under lathe/ get --lathe. Per file:
#   check    must exit 0, 1 or 2 (never >= 64, never a signal); on 2, stderr must hold at least one
#            located error line "FILE:LINE:COL: error: PP-E…: ".
#   convert  (no options) must either refuse (exit 2, and no output file exists) or exit 0 with
#            an output byte-identical to the input.
# At least 20 files must be accepted by check (exit 0 or 1), so a regression that refuses
# everything fails. Exit 77 (skipped) when CORPUS_DIR does not exist.
set -uo pipefail

if [[ $# -ne 2 ]]; then
  echo "usage: $0 POSTPROC_BINARY CORPUS_DIR" >&2
  exit 64
fi
bin=$(realpath "$1")
corpus=$2
if [[ ! -d "$corpus" ]]; then
  echo "corpus_test: SKIPPED: corpus folder '$corpus' does not exist (it lives in shared/corpus beside the repository)"
  exit 77
fi
corpus=$(realpath "$corpus")
manifest="$corpus/MANIFEST.tsv"
[[ -f "$manifest" ]] || { echo "corpus_test: $manifest is missing" >&2; exit 1; }
# 22 since a LinuxCNC file of subroutine definitions only (lcnc_twp_square.ngc) is read as rs274 runs it, with
# the warning PP-U223; 21 since reader round 2 (19 since issue 3: check follows subprogram calls, and
# gcw_sinumerik850_rparams.nc calls L100, a machine subprogram that is not in the corpus, refused with PP-E704).
readonly min_accepted=22

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$corpus" || exit 1  # relative paths: the file names in messages hold no ':'

failures=0 accepted=0 refused=0 converted=0 total=0
fail() {
  echo "FAIL $1: $2"
  failures=$((failures + 1))
}
printf '%-58s %-15s %5s %5s %5s  %s\n' file dialect check err warn convert
while IFS=$'\t' read -r file _repo _path _commit _license dialect _rest; do
  [[ "$file" == file || -z "$file" ]] && continue
  total=$((total + 1))
  if [[ ! -f "$file" ]]; then
    fail "$file" "listed in MANIFEST.tsv but missing"
    continue
  fi
  args=()
  case "$dialect" in
    fanuc | siemens | linuxcnc | heidenhain-iso) d=$dialect ;;
    other) if [[ "${file,,}" == *millplus* ]]; then d=heidenhain-iso; else d=fanuc; fi ;;
    *) fail "$file" "unknown dialect '$dialect' in MANIFEST.tsv"; continue ;;
  esac
  args+=(--dialect "$d")
  [[ "$d" == fanuc && "$file" == lathe/* ]] && args+=(--lathe)

  "$bin" check "${args[@]}" "$file" > "$work/check.out" 2> "$work/check.err" < /dev/null
  rc=$?
  located=$(grep -cE '^[^:]+:[0-9]+:[0-9]+: error: PP-E[0-9]+: ' "$work/check.err")
  # Totals from the summary ("result: refused (N errors)", "unresolved constructs: PP-U201 ×3, …").
  errors=$(sed -nE 's/^  result: refused \(([0-9]+) errors?\)$/\1/p' "$work/check.out")
  warnings=$(sed -nE 's/^  unresolved constructs: //p' "$work/check.out" | grep -oE '×[0-9]+' | tr -d '×' |
    awk '{ s += $1 } END { print s + 0 }')
  case $rc in
    0 | 1) accepted=$((accepted + 1)) ;;
    2)
      refused=$((refused + 1))
      [[ $located -gt 0 ]] || fail "$file" "check exit 2 without a located 'FILE:LINE:COL: error: PP-E…: ' line"
      ;;
    *)
      fail "$file" "check exit $rc (crash or unexpected failure); stderr tail:"
      tail -n 5 "$work/check.err"
      ;;
  esac

  out="$work/converted"
  rm -f "$out"
  "$bin" convert "${args[@]}" "$file" -o "$out" > "$work/conv.out" 2> "$work/conv.err" < /dev/null
  crc=$?
  if [[ $crc -eq 0 ]]; then
    if cmp -s "$file" "$out"; then
      conv="identical"
      converted=$((converted + 1))
    else
      conv="DIFFERS"
      fail "$file" "convert exit 0 but the output differs from the input: $(cmp "$file" "$out" 2>&1 | head -n 1)"
    fi
  elif [[ $crc -eq 2 ]]; then
    conv="refused"
    [[ -e "$out" ]] && fail "$file" "convert refused (exit 2) but left an output file"
    [[ $rc -eq 2 ]] || fail "$file" "convert refused (exit 2) a program check accepted (exit $rc)"
  else
    conv="exit $crc"
    fail "$file" "convert exit $crc; stderr tail:"
    tail -n 5 "$work/conv.err"
  fi
  # Leftover temporary files beside the output would mean convert is not atomic.
  leftovers=$(find "$work" -maxdepth 1 -name 'converted?*' | wc -l)
  [[ $leftovers -eq 0 ]] || fail "$file" "convert left $leftovers temporary file(s) beside the output"
  printf '%-58s %-15s %5s %5s %5s  %s\n' "$file" "$d${args[2]:+ lathe}" "$rc" "${errors:-0}" "$warnings" "$conv"
done < "$manifest"

echo
echo "corpus: $total files, $accepted accepted by check (0/1), $refused refused (2), $converted converted identically"
[[ $total -gt 0 ]] || fail MANIFEST.tsv "lists no files"
if [[ $accepted -lt $min_accepted ]]; then
  fail corpus "only $accepted files accepted by check; at least $min_accepted expected"
fi
if [[ $failures -gt 0 ]]; then
  echo "corpus_test: $failures failure(s)"
  exit 1
fi
echo "corpus_test: all checks passed"
exit 0
