#!/usr/bin/env bash
# Issue 3: the motions `postproc dump` gives for LinuxCNC programs with parameters, expressions,
# O-word subroutines and control flow agree with LinuxCNC's own interpreter (`rs274 -g`, Debian
# package linuxcnc-uspace, installed by scripts/install-deps.sh --test): the same sequence of straight
# moves, end points equal to rs274's 4 printed decimals.
# Usage: rs274_compare.sh POSTPROC SOURCE_DIR
set -u
P=$(realpath "$1")
SRC=$(realpath "$2")
D="$SRC/tests/resolve/linuxcnc"
command -v rs274 > /dev/null || { echo "FAIL: rs274 missing (scripts/install-deps.sh --test installs linuxcnc-uspace)"; exit 1; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# rs274 keeps its tool table in $HOME/.tool.mmap, shared by every rs274 running at once (another
# worktree's tests): each run here gets a HOME of its own.
mkdir -p "$T/home"
export HOME="$T/home"
fails=0
# comp_*: cutter radius compensation (G41/G42, G41.1/G42.1, G40; docs/dialects.md), with the tool
# table comp_tools.tbl (inches for rs274, the same in mm for postproc): straight moves and arcs (end
# point, centre, direction, turns) move for move (tests/rs274_moves.py).
for prog in comp_lines comp_arcs comp_entry comp_z_g91 comp_g18 comp_dynamic comp_inch comp_lathe; do
  python3 "$SRC/tests/rs274_moves.py" "$P" "$D/$prog.ngc" "$D/comp_tools.tbl" || fails=$((fails + 1))
done
# lathe_*: LinuxCNC G70/G71/G72 turning cycles and G33 (docs/lathe-cycles.md); their arcs (G18: ARC_FEED
# first axis Z, second X) are compared too: end point, centre and direction.
# reader_*: constructs of the LinuxCNC reader (issue 16), each checked against rs274 on traps; drilling
# rows (one per hole) are expanded into rs274's moves (lcnc_samples_compare.expand_drilling); inch
# output of rs274 is converted to mm.
for prog in control_flow expressions subroutines lathe_g70 lathe_g70_entry lathe_rough_levels lathe_g71 lathe_g72 lathe_pocket lathe_pocket_only lathe_corners lathe_g33 reader_dwell reader_modal_state reader_polar_cycles reader_m73 reader_g7x_statements reader_oword_spacing reader_after_end reader_closing_percent reader_expression_rules reader_spaced_words reader_m72_tool_length reader_loop_flags reader_oword_computed reader_program_number reader_loop_breaks; do
  (cd "$D" && timeout 60 rs274 -g "$prog.ngc") > "$T/$prog.rs274" 2>&1
  # Exit 1 (warnings) only for what LinuxCNC says too: text after the program's end (PP-W210) and
  # a program without its end (PP-W211).
  rc=0
  (cd "$D" && "$P" dump "$prog.ngc" --dialect linuxcnc --format csv) > "$T/$prog.csv" 2> "$T/$prog.err" || rc=$?
  if [ "$rc" -ne 0 ] && { [ "$rc" -ne 1 ] || grep -E ": (warning|error): PP-" "$T/$prog.err" | grep -qvE "PP-W21[01]:"; }; then
    echo "FAIL: $prog: dump failed: $(cat "$T/$prog.err")"; fails=$((fails + 1)); continue
  fi
  python3 - "$T/$prog.rs274" "$T/$prog.csv" "$prog" "$SRC/tests" <<'PY' || fails=$((fails + 1))
import csv, re, sys
sys.path.insert(0, sys.argv[4])
from lcnc_samples_compare import expand_drilling
name = sys.argv[3]
arcs = name.startswith("lathe_")
ref, units, tol = [], 1.0, []
for line in open(sys.argv[1]):
    m = re.search(r"USE_LENGTH_UNITS\(CANON_UNITS_(\w+)\)", line)
    if m:
        units = 25.4 if m.group(1) == "INCHES" else 1.0
    m = re.search(r"STRAIGHT_(FEED|TRAVERSE)\(([^)]*)\)", line)
    if m:
        v = [float(x) for x in m.group(2).split(",")[:6]]
        ref.append([x * units for x in v[:3]] + v[3:])
        tol.append(6e-5 * units)  # rs274 prints 4 decimals of its units
        continue
    m = re.search(r"ARC_FEED\(([^)]*)\)", line)
    if m and arcs:
        v = [float(x) for x in m.group(1).split(",")]
        pos = list(ref[-1][:6]) if ref else [0.0] * 6
        pos[0], pos[2] = v[1] * units, v[0] * units
        ref.append(pos + [v[3] * units, v[2] * units, 1.0 if v[4] > 0 else -1.0])
        tol.append(6e-5 * units)
rows = expand_drilling(list(csv.DictReader(open(sys.argv[2]))))
if rows is None:
    print(f"FAIL: {name}: a drilling cycle other than G81/G82 in G17 cannot be compared"); sys.exit(1)
got, last = [], [0.0] * 6
for r in rows:
    arc = r["motion"] in ("cw", "ccw")
    if r["motion"] not in ("rapid", "linear") and not (arcs and arc):
        continue
    for k, a in enumerate("xyzabc"):
        if r.get(a) not in (None, "", "null"):
            last[k] = float(r[a])
    extra = [float(r["centre_x"]), float(r["centre_z"]), 1.0 if float(r["sweep_deg"]) > 0 else -1.0] if arc else []
    got.append((int(r["line"]), list(last) + extra))
if not ref:
    print(f"FAIL: {name}: rs274 gave no moves"); sys.exit(1)
if len(ref) != len(got):
    print(f"FAIL: {name}: rs274 {len(ref)} moves, postproc {len(got)}"); sys.exit(1)
for i, (a, (line, b)) in enumerate(zip(ref, got)):
    if len(a) != len(b) or any(abs(x - y) > tol[i] for x, y in zip(a, b)):
        print(f"FAIL: {name}: move {i + 1} (source line {line}): rs274 {a}, postproc {b}"); sys.exit(1)
print(f"{name}: {len(ref)} moves agree with rs274")
PY
done
# LinuxCNC's line length limit ("Command too long"), on lines run, skipped over and after M2.
python3 "$SRC/tests/rs274_line_length.py" "$P" || fails=$((fails + 1))
[[ $fails -eq 0 ]] || { echo "$fails program(s) differ"; exit 1; }
