#!/usr/bin/env python3
"""The moves of a LinuxCNC program as LinuxCNC's own interpreter prints them (`rs274 -g`, Debian
package linuxcnc-uspace) and as `postproc dump --format csv` gives them, in one form, to compare
move for move: straight moves (end point X Y Z A B C) and arcs (end point, centre in the plane,
direction and turns). Used by rs274_compare.sh (the cutter radius compensation programs) and
cutter_comp_property.py.

rs274 keeps its tool table in a file shared through $HOME (~/.tool.mmap): two rs274 runs at once
(another test, another worktree) read each other's tables. Each run here gets a HOME of its own.
rs274 reads its tool table (-t) in inches; postproc's --tool-table is in mm: mm_tool_table() writes
the same table in mm. rs274 prints 4 decimals of its length units (inch output is converted to mm);
moves agree within 6e-5 of those units. A straight move that ends where the previous move ended is
left out on both sides (rs274 prints one for a block holding only G0 or G1, where postproc has no
motion).

Usage: rs274_moves.py POSTPROC PROGRAM.ngc [RS274_TOOL_TABLE] — compares one program, exit 1 on a
difference.
"""
import csv, io, os, re, subprocess, sys, tempfile

LETTERS = "xyzabc"
# The plane's first and second axis as ARC_FEED gives them, and the normal (rs274 SELECT_PLANE).
PLANES = {"XY": (0, 1, 2), "XZ": (2, 0, 1), "YZ": (1, 2, 0)}


def mm_tool_table(inch_table, out_path):
    """Writes `inch_table` (rs274's units) with its lengths and diameters in mm."""
    with open(inch_table) as f, open(out_path, "w") as o:
        for line in f:
            body, _, rem = line.partition(";")
            words = []
            for w in body.split():
                if w[0].upper() in "XYZUVWD":
                    w = w[0] + repr(float(w[1:]) * 25.4)
                words.append(w)
            o.write(" ".join(words) + (" ;" + rem.rstrip("\n") if rem else "") + "\n")


def run(program, table=None, cwd=None, timeout=60):
    """rs274's printed output (stdout and stderr) for `program`, with its own HOME; None on a timeout."""
    args = ["rs274", "-g", os.path.basename(program)] + (["-t", os.path.abspath(table)] if table else [])
    try:
        with tempfile.TemporaryDirectory() as home:
            out = subprocess.run(args, cwd=cwd or os.path.dirname(os.path.abspath(program)), capture_output=True,
                                 text=True, timeout=timeout, env=dict(os.environ, HOME=home))
    except subprocess.TimeoutExpired:
        return None
    # A crash (rs274 2.9's G7x code can end in a segmentation fault) is LinuxCNC not running it.
    crashed = f"\nrs274 crashed (signal {-out.returncode})\n" if out.returncode < 0 else ""
    return out.stdout + out.stderr + crashed


def canon(text):
    """The canonical calls rs274 printed, one (name, numbers, units, plane) per call: `units` is the
    factor to mm of its lengths (25.4 after CANON_UNITS_INCHES), `plane` the plane selected then. A
    line that is neither a call nor 'executing' is rs274's error: ("error", text, units, plane),
    except the debugging line "Oops (z,x)" its G7x offset prints where it drops an element that
    turned back (interp_g7x.cc, add_distance): the cycle goes on."""
    units, plane = 1.0, "XY"
    for line in text.splitlines():
        m = re.match(r"\s*\d+ N\S*\s+(\w+)\((.*)\)\s*$", line)
        if not m:
            if line.strip() and not re.match(r"\s*\d+ N", line) and line.strip() != "executing" \
                    and not line.startswith("Oops ("):
                yield "error", line.strip(), units, plane
            continue
        name, args = m.group(1), m.group(2)
        if name == "USE_LENGTH_UNITS":
            units = 25.4 if "INCHES" in args else 1.0
        elif name == "SELECT_PLANE":
            plane = args.replace("CANON_PLANE_", "").strip()
        nums = []
        for x in args.split(","):
            try:
                nums.append(float(x))
            except ValueError:
                pass
        yield name, nums, units, plane


def rs274(program, table=None, cwd=None):
    """(moves, error, block): LinuxCNC's moves, its error text (None when it ran to the end) and the
    text of the block it stopped at."""
    text = run(program, table, cwd) or "timeout"
    errors = [a for n, a, _, _ in canon(text) if n == "error"]
    error = errors[0] if errors else None  # rs274 prints its error, then the block it stopped at
    stopped_at = errors[1] if len(errors) > 1 else None
    moves = []
    for name, v, units, plane in canon(text):
        if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            moves.append({"kind": "L", "end": [x * units for x in v[:3]] + v[3:6], "tol": 6e-5 * units})
        elif name == "RIGID_TAP":  # G33.1: to the point and back to where it started
            last = moves[-1]["end"] if moves else [0.0] * 6
            moves.append({"kind": "L", "end": [x * units for x in v[:3]] + last[3:6], "tol": 6e-5 * units})
            moves.append({"kind": "L", "end": list(last), "tol": 6e-5 * units})
        elif name == "ARC_FEED":
            u, w, n = PLANES[plane]
            end = [0.0] * 3
            end[u], end[w], end[n] = v[0] * units, v[1] * units, v[5] * units
            centre = {u: v[2] * units, w: v[3] * units}
            moves.append({"kind": "A", "end": end + v[6:9], "centre": centre, "turn": int(v[4]),
                          "tol": 6e-5 * units})
    return without_zero_length(moves), error, stopped_at


def postproc(postproc_bin, program, mm_table=None, cwd=None):
    """(moves, exit code, stderr) of `postproc dump`."""
    args = [postproc_bin, "dump", os.path.basename(program), "--dialect", "linuxcnc", "--format", "csv"]
    if mm_table:
        args += ["--tool-table", os.path.abspath(mm_table)]
    out = subprocess.run(args, cwd=cwd or os.path.dirname(os.path.abspath(program)), capture_output=True, text=True,
                         timeout=120)
    rows = list(csv.DictReader(io.StringIO(out.stdout))) if out.stdout.startswith("line") else []
    moves, last = [], [0.0] * 6
    for r in rows:
        if r["motion"] not in ("rapid", "linear", "cw", "ccw"):
            continue
        for k, a in enumerate(LETTERS):
            last[k] = float(r[a]) if r.get(a) not in (None, "", "null") else None
        mv = {"kind": "L", "end": list(last), "line": int(r["line"]), "tol": 6e-5}
        if r["motion"] in ("cw", "ccw"):
            mv["kind"] = "A"
            mv["centre"] = {k: float(r["centre_" + a]) if r.get("centre_" + a) not in (None, "") else None
                            for k, a in enumerate("xyz")}
            turns = int(r["turns"]) if r.get("turns") not in (None, "") else 1
            mv["turn"] = turns if r["motion"] == "ccw" else -turns
        moves.append(mv)
    return without_zero_length(moves), out.returncode, out.stderr


def without_zero_length(moves):
    """Drops straight moves shorter than what rs274 prints (4 decimals: `tol`) on every axis."""
    out, last = [], [0.0] * 6
    for mv in moves:
        e = mv["end"]
        if mv["kind"] == "L" and all(a is None or b is None or abs(a - b) < mv.get("tol", 1e-6) for a, b in zip(e, last)):
            last = [b if a is None else a for a, b in zip(e, last)]
            continue
        out.append(mv)
        last = [b if a is None else a for a, b in zip(e, last)]
    return out


def differ(ref, got):
    """None when the two lists agree, else the first difference described. A position postproc does not
    know (an axis before the program names it: rs274 prints 0 there) is not compared; a move left
    unknown by a refusal comes with a diagnostic, and postproc's exit code fails the comparison."""
    if len(ref) != len(got):
        n = min(len(ref), len(got))
        for i in range(n):
            d = differ_one(ref[i], got[i])
            if d:
                return f"move {i + 1}: {d} (rs274 {len(ref)} moves, postproc {len(got)})"
        return f"rs274 {len(ref)} moves, postproc {len(got)}"
    for i, (a, b) in enumerate(zip(ref, got)):
        d = differ_one(a, b)
        if d:
            return f"move {i + 1} (source line {b.get('line', '?')}): {d}"
    return None


def differ_one(a, b):
    if a["kind"] != b["kind"]:
        return f"rs274 {'arc' if a['kind'] == 'A' else 'straight move'}, postproc {'arc' if b['kind'] == 'A' else 'straight move'}"
    tol = a["tol"]
    for k in range(6):
        if b["end"][k] is not None and abs(a["end"][k] - b["end"][k]) > tol:
            return f"end {LETTERS[k].upper()}: rs274 {a['end'][k]:.4f}, postproc {b['end'][k]}"
    if a["kind"] == "A":
        for k, v in a["centre"].items():
            if b["centre"][k] is None or abs(v - b["centre"][k]) > tol:
                return f"centre {LETTERS[k].upper()}: rs274 {v:.4f}, postproc {b['centre'][k]}"
        if a["turn"] != b["turn"]:
            return f"turn: rs274 {a['turn']}, postproc {b['turn']}"
    return None


def compare(postproc_bin, program, inch_table=None):
    """(ok, message) for one program: the same moves, or both refuse it (postproc exit 2, located)."""
    with tempfile.TemporaryDirectory() as tmp:
        mm = None
        if inch_table:
            mm = os.path.join(tmp, "tools_mm.tbl")
            mm_tool_table(inch_table, mm)
        ref, error, where = rs274(program, inch_table)
        got, rc, err = postproc(postproc_bin, program, mm)
    located = re.search(r":\d+:\d+: error: PP-E\d+", err)
    if error is not None:
        if rc == 2 and located:
            # the block rs274 stops at is one postproc refuses
            lines = open(program).read().split("\n")
            at = [int(m.group(1)) for m in re.finditer(r":(\d+):\d+: error: PP-E\d+", err)]
            # rs274 names the profile's "oN endsub" for the errors of a G70-G72 (it reads the profile
            # and cuts the cycle from there); postproc names the cycle's line.
            profile_end = where is not None and re.match(r"(?i)o\d+\s*endsub", where)
            if where is not None and not profile_end and not any(0 < n <= len(lines) and lines[n - 1].strip() == where for n in at):
                return False, f"rs274 stops at '{where}' ({error}); postproc refuses lines {at}: {err.strip()[:300]}"
            return True, f"refused by both (rs274: {error})"
        return False, f"rs274 stops ({error}) but postproc exits {rc}{'' if located else ' without a located error'}: {err.strip()[:300]}"
    if rc != 0:
        return False, f"postproc exits {rc}: {err.strip()[:400]}"
    d = differ(ref, got)
    if d:
        return False, d
    return True, f"{len(ref)} moves agree"


if __name__ == "__main__":
    ok, msg = compare(os.path.realpath(sys.argv[1]), sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else None)
    print(f"{os.path.basename(sys.argv[2])}: {msg}")
    sys.exit(0 if ok else 1)
