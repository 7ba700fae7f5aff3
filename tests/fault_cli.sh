#!/usr/bin/env bash
# Fault tests of the outputs (issue 21): kill -9, SIGINT, SIGTERM, SIGHUP, SIGPIPE and a full file
# system (a file-size limit, `ulimit -f`) during convert, compensate and batch leave the complete old
# output or the complete new one, never a partial file; no temporary is left after the next run;
# inputs are never changed, nor overwritten by any output (PP-E901), through links too; a folder as
# input is exit 66 (PP-E903); --in-place twice keeps the first original.
#
# Not timing-dependent: runs to interrupt read their program from a FIFO that the test keeps open,
# so the process is certainly running, with its temporary created, when the signal is sent. The
# batch run is interrupted at an arbitrary moment and checked for the invariants whatever it had done.
set -uo pipefail
# Job control: a non-interactive shell starts background jobs with SIGINT ignored (and postproc,
# like every program, keeps a signal ignored that it inherits ignored); with -m they get the default.
set -m
P=$(realpath "$1")
GEN=$(realpath "$2")
ROOT=$(realpath "$3")
T=$(mktemp -d)
trap 'exec 3>&- 2>/dev/null; rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
M="$ROOT/samples/machines/trunnion_ac_fanuc.toml"
cd "$T" || exit 1

"$GEN" --blocks 60000 --out big.nc --dialect fanuc > /dev/null 2>&1 || { echo "cannot generate"; exit 1; }
cp "$M" m.toml
head -n 300 big.nc > small.nc
echo M30 >> small.nc
sums() { sha256sum big.nc m.toml; }
sums > inputs.sha
inputs_unchanged() { sha256sum --quiet -c inputs.sha > /dev/null 2>&1 || fail "$1: an input changed"; }
temporaries() { find "${1:-.}" -name '*postproc-tmp*' -o -name '*.tmp.[0-9]*' | sort; }

# References: the complete new outputs.
"$P" convert big.nc -o ref_convert.nc --dialect fanuc 2> /dev/null || fail "reference convert failed"
"$P" compensate big.nc -m m.toml -o ref_comp.nc --report ref_comp.json 2> /dev/null || fail "reference compensate failed"
[[ -s ref_convert.nc && -s ref_comp.nc ]] || fail "no reference outputs"

# Starts CMD… reading program fifo.nc (held open on fd 3, part of the program written), waits for its
# temporary TEMP_GLOB to appear, and leaves the pid in $pid.
start_on_fifo() {
  rm -f fifo.nc && mkfifo fifo.nc
  "$@" 2> run.err &
  pid=$!
  exec 3> fifo.nc  # opens once postproc opens the FIFO for reading
  head -c 200000 big.nc >&3
  local n=0
  until [[ -n $(temporaries) ]]; do
    sleep 0.05
    n=$((n + 1))
    ((n < 600)) || { fail "$*: no temporary appeared"; break; }
  done
}

# 1. Signals during convert and compensate: the conventional status, the old output kept, no
#    temporary left, no report.
for cmd in convert compensate; do
  for sig in INT TERM HUP; do
    echo "old output" > out.nc
    rm -f out.json
    if [[ $cmd == convert ]]; then
      start_on_fifo "$P" convert fifo.nc -o out.nc --dialect fanuc
    else
      start_on_fifo "$P" compensate fifo.nc -m m.toml -o out.nc --report out.json
    fi
    kill -s "$sig" "$pid"
    wait "$pid"
    rc=$?
    exec 3>&-
    want=$((128 + $(kill -l "$sig")))
    [[ $rc == "$want" ]] || fail "$cmd SIG$sig: exit status $rc, expected $want"
    [[ $(cat out.nc) == "old output" ]] || fail "$cmd SIG$sig: the old output was replaced"
    [[ ! -e out.json ]] || fail "$cmd SIG$sig: a report was written"
    [[ -z $(temporaries) ]] || fail "$cmd SIG$sig: temporaries left: $(temporaries)"
  done
done

# 2. kill -9 leaves a temporary (nothing can remove it) but never a partial output; the next run on
#    the same target removes it and writes the complete output.
for cmd in convert compensate; do
  echo "old output" > out.nc
  if [[ $cmd == convert ]]; then
    start_on_fifo "$P" convert fifo.nc -o out.nc --dialect fanuc
  else
    start_on_fifo "$P" compensate fifo.nc -m m.toml -o out.nc
  fi
  kill -KILL "$pid"
  wait "$pid" 2> /dev/null
  exec 3>&-
  [[ $(cat out.nc) == "old output" ]] || fail "$cmd kill -9: the old output was replaced"
  [[ $(temporaries) == ./.out.nc.postproc-tmp.* ]] || fail "$cmd kill -9: expected the killed run's hidden temporary, found '$(temporaries)'"
  if [[ $cmd == convert ]]; then
    "$P" convert big.nc -o out.nc --dialect fanuc 2> /dev/null && cmp -s out.nc ref_convert.nc ||
      fail "convert after kill -9: output not complete"
  else
    "$P" compensate big.nc -m m.toml -o out.nc 2> /dev/null && cmp -s out.nc ref_comp.nc ||
      fail "compensate after kill -9: output not complete"
  fi
  [[ -z $(temporaries) ]] || fail "$cmd after kill -9: the next run left $(temporaries)"
done

# 3. SIGPIPE: the reader of standard output goes away; killed by SIGPIPE, no report, no temporary.
"$P" convert big.nc -o - --dialect fanuc 2> /dev/null | head -c 10 > head.out
rc=${PIPESTATUS[0]}
[[ $rc == 141 ]] || fail "convert -o - | head: exit status $rc, expected 141 (SIGPIPE)"
[[ $(head -c 10 ref_convert.nc) == "$(cat head.out)" ]] || fail "convert -o - | head: wrong bytes"
rm -f out.json
"$P" compensate big.nc -m m.toml -o - --report out.json 2> /dev/null | head -c 10 > /dev/null
rc=${PIPESTATUS[0]}
[[ $rc == 141 ]] || fail "compensate -o - | head: exit status $rc, expected 141"
[[ ! -e out.json ]] || fail "compensate -o - | head: the report was written although the program was not"
[[ -z $(temporaries) ]] || fail "SIGPIPE: temporaries left: $(temporaries)"

# 4. A full file system (file-size limit of 1 MB): exit 73, the old output and no report.
for cmd in convert compensate; do
  echo "old output" > out.nc
  rm -f out.json
  if [[ $cmd == convert ]]; then
    (ulimit -f 2048; exec "$P" convert big.nc -o out.nc --dialect fanuc) 2> run.err
  else
    (ulimit -f 2048; exec "$P" compensate big.nc -m m.toml -o out.nc --report out.json) 2> run.err
  fi
  rc=$?
  [[ $rc == 73 ]] || fail "$cmd on a full disk: exit $rc, expected 73 ($(tail -1 run.err))"
  grep -q "write failed" run.err || fail "$cmd on a full disk: no clear message: $(cat run.err)"
  [[ $(cat out.nc) == "old output" ]] || fail "$cmd on a full disk: the old output was replaced"
  [[ ! -e out.json ]] || fail "$cmd on a full disk: the report was written although the program was not"
  [[ -z $(temporaries) ]] || fail "$cmd on a full disk: temporaries left: $(temporaries)"
done
# Standard output on a full device: exit 73, and no report for the program that was not written.
rm -f out.json
"$P" compensate small.nc -m m.toml -o - --report out.json > /dev/full 2> run.err
rc=$?
[[ $rc == 73 ]] || fail "compensate -o - > /dev/full: exit $rc, expected 73"
[[ ! -e out.json ]] || fail "compensate -o - > /dev/full: the report was written although the program was not"
# A read-only folder: exit 73, nothing written (root ignores folder modes: skipped then).
mkdir ro && chmod 555 ro
if ! touch ro/probe 2> /dev/null; then
  "$P" compensate big.nc -m m.toml -o ro/out.nc --report out.json 2> run.err
  [[ $? == 73 ]] || fail "read-only folder: exit not 73"
  [[ ! -e out.json ]] || fail "read-only folder: the report was written although the program was not"
fi
rm -f ro/probe; chmod 755 ro

# 5. Batch: interrupted at any moment, or on a full disk, every output is absent or complete, no
#    temporary stays after the next run, the inputs are unchanged.
mkdir -p jobs/a jobs/b
for i in 1 2 3; do head -n 20000 big.nc > "jobs/a/p$i.nc"; echo M30 >> "jobs/a/p$i.nc"; cp "jobs/a/p$i.nc" "jobs/b/q$i.nc"; done
cp m.toml jobs/machine.toml
(cd jobs && find . -type f -exec sha256sum {} + | sort) > jobs.sha
"$P" batch jobs -o ref_out -j 2 > /dev/null 2>&1 || fail "reference batch failed"
check_batch() { # LABEL
  local f
  while IFS= read -r f; do
    [[ $f == *postproc-manifest* ]] && continue
    cmp -s "out/$f" "ref_out/$f" || fail "$1: out/$f is not the complete output"
  done < <(cd out && find . -type f ! -name '.*' | sed 's|^\./||')
  [[ $(cd jobs && find . -type f -exec sha256sum {} + | sort) == "$(cat jobs.sha)" ]] || fail "$1: an input changed"
}
for sig in INT TERM KILL; do
  rm -rf out
  "$P" batch jobs -o out -j 2 > /dev/null 2>&1 &
  pid=$!
  n=0
  until [[ -n $(temporaries out 2> /dev/null) ]] || ! kill -0 "$pid" 2> /dev/null; do
    sleep 0.01
    n=$((n + 1))
    ((n < 3000)) || break
  done
  kill -s "$sig" "$pid" 2> /dev/null
  wait "$pid"
  rc=$?
  [[ $rc == 0 || $rc == $((128 + $(kill -l "$sig"))) ]] || fail "batch SIG$sig: exit status $rc"
  [[ $sig == KILL || -z $(temporaries out) ]] || fail "batch SIG$sig: temporaries left: $(temporaries out)"
  check_batch "batch SIG$sig"
  "$P" batch jobs -o out -j 2 > /dev/null 2>&1 || fail "batch after SIG$sig: the rerun failed"
  [[ -z $(temporaries out) ]] || fail "batch after SIG$sig: the rerun left $(temporaries out)"
  check_batch "batch after SIG$sig"
done
rm -rf out
(ulimit -f 1024; exec "$P" batch jobs -o out -j 2) > /dev/null 2>&1
rc=$?
[[ $rc == 2 || $rc == 73 ]] || fail "batch on a full disk: exit $rc, expected 2 (files failed) or 73"
[[ -z $(temporaries out) ]] || fail "batch on a full disk: temporaries left: $(temporaries out)"
check_batch "batch on a full disk"

# 6. No output over an input (exit 64, PP-E901), through a symbolic and a hard link; two outputs
#    on one file (PP-E902); a folder as input (exit 66, PP-E903).
ln -s m.toml link.toml
ln m.toml hard.toml
# expect_refused RC CODE ARGS…: every run of postproc with one of the ARGS strings exits RC and
# names CODE.
expect_refused() {
  local want=$1 code=$2 args rc
  shift 2
  for args in "$@"; do
    # shellcheck disable=SC2086
    "$P" $args > /dev/null 2> run.err
    rc=$?
    [[ $rc == "$want" ]] || fail "$args: exit $rc, expected $want"
    grep -q "$code" run.err || fail "$args: no $code message: $(tail -1 run.err)"
  done
}
expect_refused 64 PP-E901 "compensate big.nc -m m.toml -o m.toml" "compensate big.nc -m m.toml -o x.nc --report m.toml" \
  "compensate big.nc -m m.toml -o link.toml" "compensate big.nc -m m.toml -o hard.toml" \
  "compensate big.nc -m m.toml -o x.nc --report big.nc"
# predict, diff and calibrate: reports and machine files over the machine, measurement and
# --validate files.
cp "$ROOT/samples/machines/hybrid_3prs_doc001_nominal.toml" nominal.toml
cp "$ROOT/samples/measurements/hybrid_3prs_poses5.csv" p5.csv
cp "$ROOT/samples/measurements/hybrid_3prs_poses6.csv" p6.csv
cp "$ROOT/samples/measurements/hybrid_3prs_attitudes.csv" att.csv
sha256sum small.nc nominal.toml p5.csv p6.csv att.csv >> inputs.sha
expect_refused 64 PP-E901 "predict small.nc -m m.toml --json m.toml" "diff small.nc small.nc -m m.toml --json link.toml" \
  "calibrate -m nominal.toml p5.csv att.csv -o p5.csv" "calibrate -m nominal.toml p6.csv --validate p5.csv -o c.toml --report p5.csv" \
  "calibrate -m nominal.toml p6.csv -o c.toml --report p6.csv"
[[ ! -e c.toml ]] || fail "a refused calibrate wrote c.toml"
"$P" compensate big.nc -m m.toml -o x.nc --report x.nc > /dev/null 2> run.err
[[ $? == 64 ]] && grep -q PP-E902 run.err || fail "two outputs on one file: not refused with PP-E902"
[[ ! -e x.nc ]] || fail "a refused run wrote x.nc"
mkdir d.nc
expect_refused 66 PP-E903 "check d.nc --dialect fanuc" "check d.nc" "convert d.nc -o y.nc --dialect fanuc" \
  "compensate d.nc -m m.toml -o y.nc" "compensate big.nc -m d.nc -o y.nc"
inputs_unchanged "links and folders"

# 7. --in-place twice: the first original stays the backup; the second run is refused (PP-E620).
head -n 2000 big.nc > ip.nc
echo M30 >> ip.nc
cp ip.nc ip.orig
"$P" compensate ip.nc -m m.toml -o ip.nc --in-place 2> /dev/null || fail "--in-place: first run failed"
cmp -s ip.nc.bak ip.orig || fail "--in-place: the backup is not the original"
"$P" compensate ip.nc -m m.toml -o ip.nc --in-place 2> run.err
[[ $? == 2 ]] && grep -q PP-E620 run.err || fail "--in-place twice: not refused with PP-E620"
"$P" compensate ip.nc -m m.toml -o ip.nc --in-place --allow-recompensation 2> run.err || fail "--allow-recompensation failed"
grep -q PP-W901 run.err || fail "--in-place again: the kept backup is not mentioned (PP-W901)"
cmp -s ip.nc.bak ip.orig || fail "--in-place twice: the first original was replaced"
"$P" convert ip.orig -o ip.orig --dialect fanuc --in-place 2> /dev/null
"$P" convert ip.orig -o ip.orig --dialect fanuc --in-place 2> /dev/null
cmp -s ip.orig.bak ip.nc.bak || fail "convert --in-place twice: the first original was replaced"

inputs_unchanged "the end"
[[ -z $(temporaries) ]] || fail "temporaries left at the end: $(temporaries)"
if ((fails > 0)); then
  echo "$fails failure(s)"
  exit 1
fi
echo "fault_cli: all checks passed"
