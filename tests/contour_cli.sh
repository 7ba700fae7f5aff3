#!/usr/bin/env bash
# End-to-end runs of `postproc predict`, `compensate --mode contour|all` and `simulate` on the
# three contour samples (issue 6): the time-domain simulation of the compensated program, measured
# against the original's intended contour, must cut the largest tool-tip and tool-axis contour
# errors by at least 90 %; reports are written; untouched lines stay byte for byte; bad input is
# refused with located diagnostics.
# Usage: contour_cli.sh POSTPROC SOURCE_DIR
set -u
P=$1
SRC=$2
M=$SRC/samples/machines
S=$SRC/samples/programs
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# The first value of key $3 after the line that opens object $2 (nlohmann dump(2): one key per line).
json_in() { awk -v obj="\"$2\":" -v key="\"$3\":" 'index($0, obj) {inside = 1} inside && index($0, key) {gsub(/[ ,]/, "", $2); print $2; exit}' FS=': ' "$1"; }
json_top() { awk -v key="\"$2\":" 'index($0, key) {gsub(/[ ,]/, "", $2); print $2; exit}' FS=': ' "$1"; }
# a ≤ f·b
le_frac() { awk -v a="$1" -v b="$2" -v f="$3" 'BEGIN {exit !(a != "" && b != "" && a + 0 <= f * b)}'; }

check_sample() {  # name program machine
  local name=$1 prog=$S/$2 mach=$M/$3
  "$P" predict "$prog" -m "$mach" --csv "$T/$name.csv" --json "$T/$name.json" --html "$T/$name.html" 2> "$T/$name.predict.err" ||
    { fail "$name: predict failed: $(cat "$T/$name.predict.err")"; return; }
  local rows
  rows=$(wc -l < "$T/$name.csv")
  [[ $rows -gt 1000 ]] || fail "$name: predict CSV has $rows lines"
  head -1 "$T/$name.csv" | grep -q 'tip_um' || fail "$name: CSV header without tip_um"
  grep -q '<svg' "$T/$name.html" || fail "$name: no plot in the HTML report"
  grep -v 'xmlns="http://www.w3.org/2000/svg"' "$T/$name.html" | grep -q 'src="http\|href="http' &&
    fail "$name: the HTML report loads network resources"
  local fit
  fit=$(json_top "$T/$name.json" fit_residual_um)
  le_frac "$fit" 0.1 1 || fail "$name: NURBS fit residual $fit µm > 0.1 µm"

  "$P" compensate "$prog" -m "$mach" --mode contour -o "$T/$name.c" --report "$T/$name.report.json" \
    --html "$T/$name.c.html" 2> "$T/$name.c.err" ||
    { fail "$name: compensate --mode contour failed: $(cat "$T/$name.c.err")"; return; }
  grep -q 'compensate mode=contour' "$T/$name.c" || fail "$name: no header naming the mode"
  grep -q '<svg' "$T/$name.c.html" || fail "$name: no plot in the compensate HTML report"
  grep -q '"history_tip_um"' "$T/$name.report.json" || fail "$name: no iteration history in the report"
  # Comment lines and the program end are copied byte for byte.
  diff <(grep '^(' "$prog") <(grep '^(' "$T/$name.c" | grep -v 'compensate mode=') > /dev/null ||
    fail "$name: comment lines changed"
  [[ $(tail -3 "$prog") == $(tail -3 "$T/$name.c") ]] || fail "$name: the program end changed"

  "$P" simulate "$prog" -m "$mach" --json "$T/$name.s0.json" 2> /dev/null || fail "$name: simulate (original) failed"
  "$P" simulate "$T/$name.c" --reference "$prog" -m "$mach" --json "$T/$name.s1.json" 2> "$T/$name.s1.err" ||
    fail "$name: simulate (compensated) failed"
  grep -q "PP-W622" "$T/$name.s1.err" && fail "$name: PP-W622 with --reference"
  # Without --reference the written program is measured against its own (lead) points: warned at
  # its header line (PP-W622), which names the machine file for the command to run instead.
  local hl
  hl=$(grep -n 'compensate mode=contour' "$T/$name.c" | head -1 | cut -d: -f1)
  for cmd in simulate predict; do
    "$P" $cmd "$T/$name.c" -m "$mach" 2> "$T/$name.own.err" > /dev/null || fail "$name: $cmd (compensated) failed"
    grep -q "$name.c:$hl:[0-9]*: warning: PP-W622: .*--reference ORIGINAL" "$T/$name.own.err" ||
      fail "$name: $cmd of the compensated program without a located PP-W622: $(head -2 "$T/$name.own.err")"
  done
  local t0 t1 a0 a1
  t0=$(json_in "$T/$name.s0.json" tip_um max)
  t1=$(json_in "$T/$name.s1.json" tip_um max)
  a0=$(json_in "$T/$name.s0.json" axis_arcsec max)
  a1=$(json_in "$T/$name.s1.json" axis_arcsec max)
  le_frac "$t1" "$t0" 0.1 || fail "$name: simulated max tool-tip contour error $t0 → $t1 µm, less than a 90 % cut"
  if awk -v a="$a0" 'BEGIN {exit !(a > 0.01)}'; then
    le_frac "$a1" "$a0" 0.1 || fail "$name: simulated max tool-axis contour error $a0 → $a1 arcsec, less than a 90 % cut"
  fi
  echo "$name: simulated tool tip $t0 → $t1 µm, tool axis $a0 → $a1 arcsec; NURBS fit residual $fit µm"
}

check_sample cone cone_frustum_nas979.nc trunnion_ac_fanuc.toml
check_sample lathe freeform_lathe_contour.ngc lathe_xzbc_doc004.toml
check_sample pocket tilted_pocket_3prs_contour.nc hybrid_3prs_doc001.toml

# --mode all: geometric remap, then contour; judged against the nominal machine's path.
if "$P" compensate "$S/cone_frustum_nas979.nc" -m "$M/trunnion_ac_fanuc.toml" --mode all -o "$T/all.nc" 2> /dev/null; then
  "$P" simulate "$S/cone_frustum_nas979.nc" -m "$M/trunnion_ac_fanuc.toml" --nominal-reference --json "$T/all0.json" 2> /dev/null
  "$P" simulate "$T/all.nc" --reference "$S/cone_frustum_nas979.nc" -m "$M/trunnion_ac_fanuc.toml" --nominal-reference \
    --json "$T/all1.json" 2> /dev/null
  t0=$(json_in "$T/all0.json" tip_um max)
  t1=$(json_in "$T/all1.json" tip_um max)
  le_frac "$t1" "$t0" 0.02 || fail "all: geometric + servo error $t0 → $t1 µm, less than a 98 % cut"
  echo "all: geometric + servo tool-tip error $t0 → $t1 µm"
else
  fail "compensate --mode all failed"
fi

# diff (issue 7): the compensated cone against the original, paired by block; --fail-above decides
# the exit code.
if "$P" diff "$S/cone_frustum_nas979.nc" "$T/cone.c" -m "$M/trunnion_ac_fanuc.toml" --json "$T/diff.json" \
     --csv "$T/diff.csv" 2> "$T/diff.err"; then
  grep -q '"aligned": "by block"' "$T/diff.json" || fail "diff: not aligned by block"
  dmax=$(json_in "$T/diff.json" deviation max_um)
  awk -v a="$dmax" 'BEGIN {exit !(a > 1 && a < 20)}' || fail "diff: max tool-tip change $dmax µm outside 1 … 20 µm"
  [[ $(wc -l < "$T/diff.csv") -gt 1600 ]] || fail "diff: CSV too short"
else
  fail "diff failed: $(cat "$T/diff.err")"
fi
"$P" diff "$S/cone_frustum_nas979.nc" "$T/cone.c" -m "$M/trunnion_ac_fanuc.toml" --fail-above 0.5 2> /dev/null
[[ $? -eq 1 ]] || fail "diff --fail-above 0.5: exit code is not 1"
"$P" diff "$S/cone_frustum_nas979.nc" "$T/cone.c" -m "$M/trunnion_ac_fanuc.toml" --fail-above 1000 2> /dev/null ||
  fail "diff --fail-above 1000: exit code is not 0"

# Refusals: a feed move without F, a machine without servo data; nothing written.
printf 'G90 G54\nG0 X0 Y0 Z0 A0 C0\nG1 X10.\nM30\n' > "$T/nofeed.nc"
"$P" predict "$T/nofeed.nc" -m "$M/trunnion_ac_fanuc.toml" 2> "$T/nofeed.err"
[[ $? -eq 2 ]] || fail "no feed: exit code is not 2"
grep -q "nofeed.nc:3:1: error: PP-E612" "$T/nofeed.err" || fail "no feed: no located PP-E612: $(cat "$T/nofeed.err")"
sed 's/^kv = .*//' "$M/lathe_xzbc_doc004.toml" > "$T/nokv.toml"
"$P" compensate "$S/freeform_lathe_contour.ngc" -m "$T/nokv.toml" --mode contour -o "$T/nokv.ngc" 2> "$T/nokv.err"
[[ $? -eq 2 ]] || fail "no kv: exit code is not 2"
grep -q "PP-E611" "$T/nokv.err" && grep -q "\[axes.X\]" "$T/nokv.err" || fail "no kv: no PP-E611 naming [axes.X]: $(cat "$T/nokv.err")"
[[ -e $T/nokv.ngc ]] && fail "no kv: output written"

if [[ $failures -gt 0 ]]; then
  echo "$failures failure(s)"
  exit 1
fi
echo "contour CLI: all checks passed"
