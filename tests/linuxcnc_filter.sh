#!/usr/bin/env bash
# postproc as a LinuxCNC program filter ([FILTER] in the INI, docs/linuxcnc-filter.md), run the way
# LinuxCNC's GUIs run one (AXIS's filter_program, /usr/bin/axis; gladevcp/qtvcp's FilterProgram):
# `sh -c "<filter> '<file>'"` with the file name quoted for the shell, stdin closed, stdout
# redirected to the program LinuxCNC loads, AXIS_PROGRESS_BAR=1 in the environment, stderr lines
# "FILTER_PROGRESS=N" read as progress and every other line shown as the error when the exit
# status is not 0. The filtered program must equal `compensate -o` on the same input and be
# accepted by LinuxCNC's own interpreter (rs274); a refused program exits non-zero with the
# located diagnostic and leaves nothing on stdout. Usage: linuxcnc_filter.sh POSTPROC SOURCE_DIR
set -u
P=$1
SRC=$2
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
M=$SRC/samples/machines/lathe_xzbc_doc004.toml
# A name with a space and a quote: the GUIs quote it as '...'\''...'.
IN="$T/it's a lathe.ngc"
cp "$SRC/samples/programs/freeform_lathe_xzbc.ngc" "$IN"
run_filter() {  # run_filter FILTER INFILE OUTFILE ERRFILE → exit status of the filter
  python3 - "$1" "$2" "$3" "$4" <<'PY'
import os, re, subprocess, sys
program_filter, infilename, outfilename, errfile = sys.argv[1:5]
progress_re = re.compile("^FILTER_PROGRESS=(\\d*)$")
infilename_q = infilename.replace("'", "'\\''")
env = dict(os.environ)
env["AXIS_PROGRESS_BAR"] = "1"
with open(outfilename, "w") as outfile:
    p = subprocess.Popen(["sh", "-c", "%s '%s'" % (program_filter, infilename_q)], stdin=subprocess.PIPE,
                         stdout=outfile, stderr=subprocess.PIPE, env=env)
    p.stdin.close()
    err = p.stderr.read().decode()
    p.wait()
progress = [int(m.group(1)) for m in (progress_re.match(l) for l in err.splitlines()) if m]
other = [l for l in err.splitlines() if not progress_re.match(l)]
with open(errfile, "w") as f:
    f.write("progress %s\n" % " ".join(map(str, progress)))
    f.write("\n".join(other) + "\n")
sys.exit(p.returncode)
PY
}
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

FILTER="$P compensate -m $M -o -"
run_filter "$FILTER" "$IN" "$T/filtered.ngc" "$T/filter.err"
rc=$?
[[ $rc -eq 0 ]] || fail "the filter exited $rc: $(cat "$T/filter.err")"
"$P" compensate "$IN" -m "$M" -o "$T/direct.ngc" 2> /dev/null || fail "compensate -o exited non-zero"
cmp -s "$T/filtered.ngc" "$T/direct.ngc" || fail "the filtered program differs from compensate -o's"
grep -q '^progress .*100$' "$T/filter.err" || fail "no FILTER_PROGRESS lines ending at 100: $(head -1 "$T/filter.err")"
awk 'NR == 1 { for (i = 3; i <= NF; ++i) if ($i < $(i - 1)) exit 1 }' "$T/filter.err" ||
  fail "the progress goes backwards: $(head -1 "$T/filter.err")"
# LinuxCNC's interpreter reads what the filter wrote.
if command -v rs274 > /dev/null; then
  rs274 -g "$T/filtered.ngc" > "$T/rs274.out" 2>&1 < /dev/null || fail "rs274 refuses the filtered program: $(tail -3 "$T/rs274.out")"
else
  fail "rs274 missing (scripts/install-deps.sh --test installs linuxcnc-uspace)"
fi
# A program the machine cannot run: non-zero exit, the located reason on stderr, nothing on stdout.
printf 'G18 G21 G90\nG0 X20 Z5\nG1 X10 Z-2 Q7 F100\nM2\n' > "$T/bad prog.ngc"
run_filter "$FILTER" "$T/bad prog.ngc" "$T/bad_out.ngc" "$T/bad.err"
rc=$?
[[ $rc -ne 0 ]] || fail "a refused program exited 0"
grep -q "bad prog.ngc:3:" "$T/bad.err" || fail "the refusal is not located: $(cat "$T/bad.err")"
[[ -s $T/bad_out.ngc ]] && fail "a refused program wrote $(wc -c < "$T/bad_out.ngc") bytes to the GUI"
[[ $failures -eq 0 ]] || { echo "$failures failure(s)"; exit 1; }
echo "linuxcnc_filter: filtered $(wc -l < "$T/filtered.ngc") lines, $(head -1 "$T/filter.err"); refused program exit $rc"
