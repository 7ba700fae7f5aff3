#!/usr/bin/env bash
# "Did you mean" for mistyped commands and options (postproc/option_hints.cpp): exit 64 (usage),
# the unknown word named with the nearest names; valid command lines are not affected.
# One vocabulary: --json / --html for reports and --max-iterations wherever a command has them.
# Usage: cli_hints.sh POSTPROC [SOURCE_DIR]
set -u
P="$1"
SRC="${2:-}"
fail=0
expect() {  # expect RC PATTERN -- ARGS...
  local want_rc="$1" pattern="$2"
  shift 3
  local out rc
  out=$("$P" "$@" 2>&1)
  rc=$?
  if [[ "$rc" != "$want_rc" ]] || ! grep -qF -- "$pattern" <<<"$out"; then
    echo "FAIL: postproc $* → rc $rc (want $want_rc), output: $out (want: $pattern)"
    fail=1
  fi
}
expect 64 "unknown option '--machin' for 'postproc compensate'; did you mean '--machine'?" -- compensate a.nc --machin x -o y
expect 64 "'compnsate' is not a postproc command; did you mean 'compensate'?" -- compnsate
expect 64 "unknown option '--mehtod' for 'postproc calibrate'; did you mean '--method'?" -- calibrate --mehtod ridge x.csv
expect 64 "unknown option '-z' for 'postproc check'" -- check a.nc --dialect fanuc -z
expect 64 "unknown option '--hlp' for 'postproc calibrate plan'; did you mean '--help'?" -- calibrate plan --hlp
expect 64 "'frobnicate' is not a postproc command (postproc --help lists them)" -- frobnicate
expect 64 "did you mean '--refine-iterations'?" -- compensate a.nc -m m.toml -o o.nc --refine-iteration 3
# Every command's --help fits a screen (50 lines of 100 columns); --help-all has the whole text.
for c in "" check dump convert compensate diff batch calibrate "calibrate plan" "calibrate simulate" predict simulate; do
  # shellcheck disable=SC2086
  out=$(COLUMNS=100 "$P" $c --help 2>&1)
  lines=$(wc -l <<<"$out")
  widest=$(python3 -c 'import sys; print(max(len(l) for l in sys.stdin.read().split("\n")))' <<<"$out")
  if (( lines > 50 || widest >= 100 )); then
    echo "FAIL: postproc $c --help: $lines lines, widest $widest columns (a screen: 50 × 100)"
    fail=1
  fi
done
out=$(COLUMNS=100 "$P" compensate --help-all 2>&1)
grep -q "warning PP-W005 either way" <<<"$out" || { echo "FAIL: compensate --help-all lacks the whole --dialect text"; fail=1; }
grep -q "has them whole" <<<"$out" && { echo "FAIL: --help-all says it is shortened"; fail=1; }
grep -q "has them whole" <<<"$(COLUMNS=100 "$P" compensate --help 2>&1)" || { echo "FAIL: --help does not point to --help-all"; fail=1; }
# Valid lines keep CLI11's own messages and codes.
expect 0 "postproc" -- --version
expect 0 "Usage:" -- check --help
expect 64 "--machine is required" -- compensate a.nc -o o.nc
expect 64 "contuor not in" -- compensate a.nc -m m.toml -o o.nc --mode contuor
# A valid line with option values runs as before.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf 'G0 X1.\nM30\n' > "$tmp/p.nc"
expect 0 "result: accepted" -- check "$tmp/p.nc" --dialect=fanuc --max-per-code 5
if [[ -n "$SRC" ]]; then
  S="$SRC/samples"
  expect 0 "" -- compensate "$S/programs/cone_frustum_nas979.nc" -m "$S/machines/trunnion_ac_fanuc.toml" \
    -o "$tmp/c.nc" --json "$tmp/c.json" --max-iterations 3
  grep -q '"mode": "geometric"' "$tmp/c.json" 2>/dev/null || { echo "FAIL: compensate --json wrote no report"; fail=1; }
  expect 0 "" -- calibrate "$S/measurements/trunnion_bc_positions.csv" -m "$S/machines/trunnion_bc_fanuc_nominal.toml" \
    -o "$tmp/cal.toml" --json "$tmp/cal.report" --html "$tmp/cal.page" --max-iterations 50
  head -c 1 "$tmp/cal.report" 2>/dev/null | grep -q '{' || { echo "FAIL: calibrate --json wrote no JSON"; fail=1; }
  grep -qi '<html' "$tmp/cal.page" 2>/dev/null || { echo "FAIL: calibrate --html wrote no HTML"; fail=1; }
  # -q: diagnostics only, no summary lines.
  out=$("$P" compensate "$S/programs/cone_frustum_nas979.nc" -m "$S/machines/trunnion_ac_fanuc.toml" -o "$tmp/q.nc" -q 2>&1)
  [[ $? == 0 && -z "$out" && -s "$tmp/q.nc" ]] || { echo "FAIL: compensate -q printed: $out"; fail=1; }
  out=$("$P" convert "$S/programs/cone_frustum_nas979.nc" --dialect fanuc --decimals X=5 -o "$tmp/q2.nc" -q 2>&1)
  [[ $? == 0 && -z "$out" && -s "$tmp/q2.nc" ]] || { echo "FAIL: convert -q printed: $out"; fail=1; }
  # --dialect on compensate and batch (one vocabulary with check/convert): the machine file's
  # dialect by default; another dialect's construct in the program is warned at its place.
  expect 2 "housing_traori.mpf:1:37: warning: PP-W005: 'TRAORI' is written by siemens programs, but this one is read as fanuc (--dialect)" \
    -- compensate "$S/programs/housing_traori.mpf" -m "$S/machines/trunnion_ac_siemens.toml" -o "$tmp/h.mpf" --dialect fanuc -q
  expect 2 "pass --dialect siemens" -- compensate "$S/programs/housing_traori.mpf" -m "$S/machines/trunnion_bc_fanuc.toml" \
    -o "$tmp/h2.mpf"
  [[ -e $tmp/h2.mpf ]] && { echo "FAIL: a refused compensate wrote its output"; fail=1; }
  out=$("$P" compensate "$S/programs/housing_traori.mpf" -m "$S/machines/trunnion_ac_siemens.toml" -o "$tmp/h3.mpf" 2>&1)
  [[ $? == 0 ]] && ! grep -q "PP-W005" <<<"$out" || { echo "FAIL: the machine file's own dialect warned: $out"; fail=1; }
  expect 0 "is read as fanuc (--dialect); the machine file" -- compensate "$S/programs/cone_frustum_nas979.nc" \
    -m "$S/machines/trunnion_ac_siemens.toml" -o "$tmp/c2.nc" --dialect fanuc
  cmp -s "$tmp/c2.nc" "$tmp/c.nc" 2>/dev/null && { echo "FAIL: a Siemens machine's correction equals the Fanuc one's"; fail=1; }
  expect 64 "unknown dialect 'fanuk' for --dialect" -- compensate "$S/programs/cone_frustum_nas979.nc" \
    -m "$S/machines/trunnion_ac_fanuc.toml" -o "$tmp/c3.nc" --dialect fanuk
  [[ -e $tmp/c3.nc ]] && { echo "FAIL: a usage error wrote its output"; fail=1; }
  mkdir -p "$tmp/job"
  cp "$S/programs/housing_traori.mpf" "$tmp/job/"
  expect 0 "" -- batch "$tmp/job" -o "$tmp/job_out" -m "$S/machines/trunnion_ac_siemens.toml" -q
  expect 2 "" -- batch "$tmp/job" -o "$tmp/job_out2" -m "$S/machines/trunnion_ac_siemens.toml" --dialect fanuc -q
  grep -q 'PP-W005' "$tmp/job_out2"/*.json 2>/dev/null || { echo "FAIL: batch --dialect fanuc: no PP-W005 in the manifest"; fail=1; }
  grep -q 'dialect=fanuc' "$tmp/job_out2"/*.json 2>/dev/null || { echo "FAIL: batch --dialect is not in the manifest's settings"; fail=1; }
  expect 64 "unknown dialect 'fanuk'" -- batch "$tmp/job" -o "$tmp/job_out3" -m "$S/machines/trunnion_ac_siemens.toml" --dialect fanuk
  # compensate --renumber: a Klartext program whose subdivided moves insert blocks comes out with
  # every block numbered 0, 1, 2 … (the TNC needs it; PP-W603 is then not said), otherwise the same.
  "$P" compensate "$S/programs/impeller_axes_bc.h" -m "$S/machines/trunnion_bc_heidenhain.toml" -o "$tmp/h1.h" \
    2> "$tmp/h1.err" || { echo "FAIL: compensate (Klartext)"; fail=1; }
  grep -q PP-W603 "$tmp/h1.err" || { echo "FAIL: Klartext with inserted blocks: no PP-W603"; fail=1; }
  "$P" compensate "$S/programs/impeller_axes_bc.h" -m "$S/machines/trunnion_bc_heidenhain.toml" -o "$tmp/h2.h" \
    --renumber 0,1 2> "$tmp/h2.err" || { echo "FAIL: compensate --renumber (Klartext)"; fail=1; }
  grep -q PP-W603 "$tmp/h2.err" && { echo "FAIL: compensate --renumber still says PP-W603"; fail=1; }
  awk '$1 != NR - 1 { bad++ } END { exit bad > 0 }' "$tmp/h2.h" || { echo "FAIL: --renumber 0,1 left blocks misnumbered"; fail=1; }
  cmp -s <(sed -E 's/^[0-9]+ *//' "$tmp/h1.h") <(sed -E 's/^[0-9]+ *//' "$tmp/h2.h") ||
    { echo "FAIL: --renumber changed more than the block numbers"; fail=1; }
  "$P" check "$tmp/h2.h" --dialect heidenhain > /dev/null 2>&1 || { echo "FAIL: the renumbered program does not read"; fail=1; }
  expect 64 "--renumber 'x': expected START[,STEP]" -- compensate "$S/programs/impeller_axes_bc.h" \
    -m "$S/machines/trunnion_bc_heidenhain.toml" -o "$tmp/h3.h" --renumber x
  # Colour: GCC's colours on a terminal or with POSTPROC_COLOR=always, none with NO_COLOR or
  # when stderr is not a terminal.
  printf '%%\nO1\nG21 G90\nG0 X0. Y0.\nG2 X5. Y5. R1. F100\nM30\n%%\n' > "$tmp/bad.nc"
  out=$(POSTPROC_COLOR=always "$P" check "$tmp/bad.nc" --dialect fanuc 2>&1)
  grep -q $'\033\[1;31merror:\033\[0m' <<<"$out" || { echo "FAIL: POSTPROC_COLOR=always: no red 'error:': $out"; fail=1; }
  grep -q $'\033\[1;32m\^' <<<"$out" || { echo "FAIL: POSTPROC_COLOR=always: no green caret: $out"; fail=1; }
  out=$(NO_COLOR=1 "$P" check "$tmp/bad.nc" --dialect fanuc 2>&1)
  grep -q $'\033' <<<"$out" && { echo "FAIL: NO_COLOR: escapes written: $out"; fail=1; }
  out=$(POSTPROC_COLOR=never "$P" check "$tmp/bad.nc" --dialect fanuc 2>&1)
  grep -q 'bad.nc:5:' <<<"$out" && ! grep -q $'\033' <<<"$out" || { echo "FAIL: POSTPROC_COLOR=never: $out"; fail=1; }
  # The progress bar fits the terminal: every redraw shorter than $COLUMNS.
  awk 'BEGIN { print "%"; print "O2"; print "G21 G90 G54"; print "G0 X0 Y0 Z50 B0 C0"; print "G1 Z5 F1000";
               for (i = 0; i < 60000; ++i) printf "X%.3f Y%.3f B%.3f C%.3f\n", 50 * cos(i / 1000), 50 * sin(i / 1000), 10 * sin(i / 500), (i / 100) % 360;
               print "M30"; print "%" }' > "$tmp/long.nc"
  for cols in 40 100; do
    COLUMNS=$cols POSTPROC_PROGRESS=1 "$P" compensate "$tmp/long.nc" -m "$S/machines/trunnion_bc_fanuc.toml" -o "$tmp/long_c.nc" 2> "$tmp/bar.err" ||
      { echo "FAIL: compensate with a progress bar"; fail=1; }
    python3 - "$tmp/bar.err" "$cols" <<'PY' || fail=1
import sys
import re
data = open(sys.argv[1], encoding="utf-8", newline="").read()  # keep the \r of the redraws
cols = int(sys.argv[2])
# Each redraw is "\r ESC[K" and the bar's text; the last clear is followed by the summary line.
draws = [d.split("\n")[0] for d in data.split("\r\033[K")[1:]]
draws = [d for d in draws if d and not re.match(r"postproc: \d+ blocks", d)]
if not draws:
    sys.exit(print("FAIL: no progress bar drawn") or 1)
long = [d for d in draws if len(d) >= cols]
if long:
    sys.exit(print(f"FAIL: {len(long)} redraws of {len(draws)} are {len(long[0])} ≥ {cols} columns: {long[0]!r}") or 1)
PY
  done
fi
if [[ $fail == 0 ]]; then echo "cli_hints: all checks passed"; fi
exit $fail
