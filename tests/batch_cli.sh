#!/usr/bin/env bash
# End-to-end test of `postproc batch` and `postproc batch merge` (issue 7) on a job-folder fixture:
# nested folders, a per-folder machine file, a malformed program, an unreadable file (a dangling
# link: root reads every file whatever its mode), a hidden folder and a file no glob takes.
# Checks outputs, manifest, exit codes, skipping on re-run, identical bytes for -j 1 and -j 2,
# shards covering every file exactly once, merge, stale-output removal and the progress display.
set -uo pipefail
P=$(realpath "$1")
ROOT=$(realpath "$2")
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
PY=/usr/bin/python3
[[ -x $PY ]] || PY=python3

M="$ROOT/samples/machines/trunnion_bc_fanuc.toml"
J="$T/jobs"
mkdir -p "$J/sub1/deeper" "$J/lathe/inner" "$J/bad" "$J/.hidden"
cp "$ROOT/samples/programs/impeller_axes_bc.nc" "$J/a.nc"
cp "$ROOT/samples/programs/impeller_axes_bc.nc" "$J/sub1/b.nc"
cp "$ROOT/samples/programs/impeller_axes_bc.nc" "$J/sub1/deeper/c.NC"   # globs ignore case
cp "$ROOT/samples/programs/freeform_lathe_xzbc.ngc" "$J/lathe/inner/d.ngc" # machine from lathe/ (nearest)
cp "$ROOT/samples/machines/lathe_xzbc_doc004.toml" "$J/lathe/machine.toml"
printf 'G1 X1..2 Y3\nM30\n' > "$J/bad/broken.nc"
ln -s "$T/does-not-exist.nc" "$J/bad/unreadable.nc"
echo "not a program" > "$J/notes.txt"
cp "$J/a.nc" "$J/.hidden/x.nc"
ALL="a.nc bad/broken.nc bad/unreadable.nc lathe/inner/d.ngc sub1/b.nc sub1/deeper/c.NC"

manifest() { # FILE EXPR: evaluates a Python expression over the manifest m
  "$PY" -c "import json,sys; m=json.load(open(sys.argv[1])); f={e['path']:e for e in m['files']}; print($2)" "$1"
}

# 1. First run, -j 1 and -j 2: outputs, exit code, no output for the bad files.
"$P" batch "$J" -m "$M" -o "$T/o1" -j 1 > "$T/o1.table" 2> "$T/o1.err"
rc=$?
[[ $rc == 2 ]] || fail "-j1: exit code $rc, expected 2 (two files not compensated)"
"$P" batch "$J" -m "$M" -o "$T/o2" -j 2 > "$T/o2.table" 2> "$T/o2.err"
[[ $? == 2 ]] || fail "-j2: exit code not 2"
for f in a.nc sub1/b.nc sub1/deeper/c.NC lathe/inner/d.ngc; do
  [[ -s "$T/o1/$f" ]] || fail "no output $f"
  cmp -s "$T/o1/$f" "$T/o2/$f" || fail "$f differs between -j 1 and -j 2"
done
for f in bad/broken.nc bad/unreadable.nc .hidden/x.nc notes.txt; do
  [[ -e "$T/o1/$f" ]] && fail "output written for $f"
done
n=$(find "$T/o1" -type f ! -name 'postproc-manifest*' | wc -l)
[[ $n == 4 ]] || fail "expected 4 outputs, found $n"
ls -a "$T/o1" "$T/o1/sub1" | grep -q '\.tmp' && fail "temporary files left in the output folder"
grep -q 'bad/broken.nc: refused: .*broken.nc:1:7: PP-E101' "$T/o1.err" || fail "refusal not listed with file:line:col: $(cat "$T/o1.err")"
grep -q 'bad/unreadable.nc: failed: .*cannot open the NC program: No such file' "$T/o1.err" || fail "unreadable file not listed"
grep -q '6 files: 4 written, 0 unchanged (skipped), 1 refused, 1 failed' "$T/o1.err" || fail "totals line: $(tail -3 "$T/o1.err")"
grep -Eq '^sub1/deeper/c.NC +written +89 ' "$T/o1.table" || fail "summary table row: $(cat "$T/o1.table")"
grep -q 'correction (mm)' "$T/o1.table" || fail "summary table heading has no unit"

# 2. The manifest: statuses, hashes of input, output and machine, per-folder machine, figures.
MF="$T/o1/postproc-manifest.json"
[[ $(manifest "$MF" "' '.join(sorted(f))") == "$ALL" ]] || fail "manifest files: $(manifest "$MF" "sorted(f)")"
[[ $(manifest "$MF" "f['a.nc']['input_sha256']") == $(sha256sum < "$J/a.nc" | cut -d' ' -f1) ]] || fail "input sha256"
for x in a.nc lathe/inner/d.ngc sub1/deeper/c.NC; do
  [[ $(manifest "$MF" "f['$x']['output_sha256']") == $(sha256sum < "$T/o1/$x" | cut -d' ' -f1) ]] || fail "output sha256 of $x"
done
[[ $(manifest "$MF" "f['lathe/inner/d.ngc']['machine']['file']") == lathe/machine.toml ]] || fail "per-folder machine not used"
[[ $(manifest "$MF" "f['lathe/inner/d.ngc']['machine']['sha256']") == $(sha256sum < "$J/lathe/machine.toml" | cut -d' ' -f1) ]] ||
  fail "per-folder machine sha256"
[[ $(manifest "$MF" "f['a.nc']['machine']['sha256']") == $(sha256sum < "$M" | cut -d' ' -f1) ]] || fail "default machine sha256"
grep -q 'machine=lathe/machine.toml' "$T/o1/lathe/inner/d.ngc" || fail "output header does not name the per-folder machine"
[[ $(manifest "$MF" "f['bad/broken.nc']['status'], f['bad/unreadable.nc']['status']") == "refused failed" ]] || fail "bad statuses"
[[ $(manifest "$MF" "f['bad/broken.nc']['diagnostics'][0]['line'], f['bad/broken.nc']['diagnostics'][0]['column']") == "1 7" ]] ||
  fail "diagnostic location in the manifest"
[[ $(manifest "$MF" "f['a.nc']['figures']['counts']['changed_blocks'] > 0 and f['a.nc']['figures']['figures']['max_correction_mm'] > 0") == True ]] ||
  fail "figures missing"
[[ $(manifest "$MF" "m['tool']['version'] == f['a.nc']['tool_version'] and m['mode'] == 'geometric'") == True ]] || fail "tool / mode"
[[ $(manifest "$MF" "m['summary']['failures']") == "['bad/broken.nc', 'bad/unreadable.nc']" ]] || fail "failure list"

# 3. Re-run: everything unchanged is skipped; a changed input, a changed machine file and a
#    changed setting are compensated again; --force redoes all.
"$P" batch "$J" -m "$M" -o "$T/o1" -j 2 -q 2> "$T/r1.err"
grep -q '6 files: 0 written, 4 unchanged (skipped), 1 refused, 1 failed' "$T/r1.err" || fail "re-run did not skip: $(tail -4 "$T/r1.err")"
cmp -s "$T/o1/a.nc" "$T/o2/a.nc" || fail "skipped output changed"
echo "(comment)" >> "$J/sub1/b.nc"
echo "# comment" >> "$J/lathe/machine.toml"
"$P" batch "$J" -m "$M" -o "$T/o1" -j 2 -q 2> "$T/r2.err"
grep -q '6 files: 2 written, 2 unchanged' "$T/r2.err" || fail "changed input / machine not redone: $(tail -4 "$T/r2.err")"
[[ $(manifest "$T/o1/postproc-manifest.json" "f['sub1/b.nc']['status'], f['lathe/inner/d.ngc']['status'], f['a.nc']['status']") == \
   "written written unchanged" ]] || fail "statuses after the change"
"$P" batch "$J" -m "$M" -o "$T/o1" -j 2 -q --max-deviation 2 2> "$T/r3.err"
grep -q '6 files: 4 written, 0 unchanged' "$T/r3.err" || fail "a changed setting did not redo the files"
echo "tampered" >> "$T/o1/a.nc"
"$P" batch "$J" -m "$M" -o "$T/o1" -j 2 -q --max-deviation 2 2> "$T/r4.err"
grep -q '6 files: 1 written, 3 unchanged' "$T/r4.err" || fail "an edited output was not rewritten: $(tail -4 "$T/r4.err")"
"$P" batch "$J" -m "$M" -o "$T/o1" -j 2 -q --max-deviation 2 --force 2> "$T/r5.err"
grep -q '6 files: 4 written, 0 unchanged' "$T/r5.err" || fail "--force did not redo the files"

# 4. A program that becomes malformed: refused, and the earlier output is removed (no stale program).
cp "$J/a.nc" "$T/a.keep"
sed -i '3a G1 X1..2' "$J/a.nc"  # inside the program (text after its M30 is never read)
"$P" batch "$J" -m "$M" -o "$T/o1" -j 2 -q --max-deviation 2 2> "$T/r6.err"
[[ -e "$T/o1/a.nc" ]] && fail "stale output of a now-refused program kept"
grep -q 'a.nc: refused: .*(the earlier output was removed)' "$T/r6.err" || fail "stale removal not reported: $(cat "$T/r6.err")"
cp "$T/a.keep" "$J/a.nc"

# 5. Shards: together they cover every file exactly once; merged outputs match the single run.
for k in 1 2 3; do
  "$P" batch "$J" -m "$M" -o "$T/os" -j 1 -q --shard $k/3 2> "$T/s$k.err"
  [[ -f "$T/os/postproc-manifest.shard-$k-of-3.json" ]] || fail "no manifest for shard $k"
done
cover=$("$PY" - "$T/os" <<'EOF'
import json, sys, glob, collections
c = collections.Counter()
for p in glob.glob(sys.argv[1] + "/postproc-manifest.shard-*-of-3.json"):
    c.update(e["path"] for e in json.load(open(p))["files"])
print(" ".join(sorted(c)), max(c.values()))
EOF
)
[[ $cover == "$ALL 1" ]] || fail "shards do not cover every file once: $cover"
"$P" batch merge "$T/os" 2> "$T/merge.err"
[[ $? == 2 ]] || fail "merge with failures must exit 2"
MM="$T/os/postproc-manifest.json"
[[ $(manifest "$MM" "m['complete'], len(f), m['summary']['written']") == "True 6 4" ]] || fail "merged manifest: $(cat "$T/merge.err")"
[[ $(manifest "$MM" "f['sub1/deeper/c.NC']['output_sha256']") == $(sha256sum < "$T/os/sub1/deeper/c.NC" | cut -d' ' -f1) ]] ||
  fail "merged manifest output hash"
cmp -s "$T/os/sub1/deeper/c.NC" "$T/o2/sub1/deeper/c.NC" || fail "shard output differs from the unsharded run"
"$P" batch merge "$T/os/postproc-manifest.shard-1-of-3.json" "$T/os/postproc-manifest.shard-3-of-3.json" -o "$T/partial.json" \
  2> "$T/partial.err"
[[ $? == 2 ]] || fail "merge with a missing shard must fail"
grep -q 'shards missing: \[2\]' "$T/partial.err" || fail "missing shard not named: $(cat "$T/partial.err")"
"$P" batch merge "$T/os/postproc-manifest.shard-1-of-3.json" "$T/os/postproc-manifest.shard-1-of-3.json" -o "$T/dup.json" \
  2> "$T/dup.err"
[[ $? == 2 ]] && grep -q 'given twice' "$T/dup.err" || fail "duplicate shard accepted: $(cat "$T/dup.err")"
# A re-run of a shard skips through its own manifest.
"$P" batch "$J" -m "$M" -o "$T/os" -j 1 -q --shard 2/3 2> "$T/s2b.err"
grep -q '0 written, .* unchanged' "$T/s2b.err" || fail "shard re-run did not skip: $(tail -3 "$T/s2b.err")"

# 6. Only good files: exit 0. Output folder inside the job folder is not walked; the job folder
#    as output is refused.
"$P" batch "$J" -m "$M" -o "$J/out" --glob '*.ngc' --glob 'sub1/*.nc' -q 2> "$T/g.err"
[[ $? == 0 ]] || fail "all-good batch exit code: $(cat "$T/g.err")"
grep -q '2 files: 2 written' "$T/g.err" || fail "globs: $(tail -2 "$T/g.err")"
"$P" batch "$J" -m "$M" -o "$J/out" --glob '*.ngc' --glob 'sub1/*.nc' -q 2> "$T/g2.err"
grep -q '2 files: 0 written, 2 unchanged' "$T/g2.err" || fail "output folder inside the job folder was walked"
"$P" batch "$J" -m "$M" -o "$J" 2> "$T/same.err"
[[ $? == 64 ]] || fail "the job folder as output folder must be refused (64)"
"$P" batch "$J/sub1" -m "$M" -o "$J" 2> "$T/inside.err"
[[ $? == 64 ]] || fail "a job folder inside the output folder must be refused (64)"
"$P" batch "$J" -m "$M" -o "$T/x" --shard 4/3 2> /dev/null
[[ $? == 64 ]] || fail "--shard 4/3 must be a usage error"
"$P" batch "$T/no-such-dir" -m "$M" -o "$T/x" 2> /dev/null
[[ $? == 66 ]] || fail "missing job folder must exit 66"

# 7. Progress: a bar when forced on (as on a terminal), plain lines otherwise.
POSTPROC_PROGRESS=1 "$P" batch "$J" -m "$M" -o "$T/o3" -j 2 -q 2> "$T/bar.err"
grep -q $'\r' "$T/bar.err" && grep -q '\[=*>* *\] *[0-9]* %' "$T/bar.err" || fail "no progress bar with POSTPROC_PROGRESS=1"
grep -q 'batch \[1/6\]' "$T/bar.err" && fail "plain per-file lines printed under the bar"
grep -q 'bad/broken.nc: refused' "$T/bar.err" || fail "failures not printed above the bar"
grep -q $'\r' "$T/o1.err" && fail "progress bar drawn when stderr is not a terminal"
grep -q 'batch \[6/6\]' "$T/o1.err" || fail "no per-file lines when stderr is not a terminal"
if command -v script > /dev/null; then  # a real terminal
  script -qec "'$P' batch '$J' -m '$M' -o '$T/o4' -j 2 -q --force" /dev/null > "$T/tty.out" 2>&1
  grep -q '%' "$T/tty.out" || fail "no progress bar on a terminal"
fi

# 8. Progress bars of single-file work: compensate, calibrate (forced on; silent otherwise).
{ echo "G90 G54 G94 F1000"; echo "G0 X0 Y0 Z50 B0 C0"; for ((i = 0; i < 20000; ++i)); do echo "G1 X$((i % 97)).5 Y$((i % 89)).25 Z10."; done; echo "M30"; } > "$T/long.nc"
POSTPROC_PROGRESS=1 "$P" compensate "$T/long.nc" -m "$M" -o "$T/long.c.nc" 2> "$T/cbar.err"
grep -q $'\r.*compensate \[' "$T/cbar.err" || fail "compensate: no progress bar: $(head -c 300 "$T/cbar.err")"
"$P" compensate "$T/long.nc" -m "$M" -o "$T/long.d.nc" 2> "$T/cnobar.err"
grep -q $'\r' "$T/cnobar.err" && fail "compensate: progress drawn when stderr is not a terminal"
cmp -s "$T/long.c.nc" "$T/long.d.nc" || fail "the progress bar changed the output"
POSTPROC_PROGRESS=1 "$P" calibrate -m "$ROOT/samples/machines/hexapod_doc003_nominal.toml" \
  "$ROOT/samples/measurements/hexapod_struts.csv" -o "$T/hex.toml" > /dev/null 2> "$T/calbar.err"
grep -q 'calibrate: solving' "$T/calbar.err" || fail "calibrate: no progress bar: $(head -c 300 "$T/calbar.err")"

if [[ $fails -gt 0 ]]; then
  echo "$fails failure(s)"
  exit 1
fi
echo "batch_cli: all checks passed"
