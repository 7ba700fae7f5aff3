#!/usr/bin/env python3
"""LinuxCNC's own sample programs through LinuxCNC's interpreter (`rs274 -g`) and `postproc dump`.

Usage: lcnc_samples_compare.py POSTPROC [--tool-table TOOLS.tbl] FILE.ngc...

With --tool-table, rs274 reads TOOLS.tbl (-t, in inches as rs274 reads its table) and postproc the
same table in mm (--tool-table): the programs under cutter radius compensation are compared for real.
Every rs274 run gets a HOME of its own (rs274 shares its tool table through ~/.tool.mmap with any
rs274 running at the same time).

Per program LinuxCNC runs without an error: postproc must either agree move for move (straight
moves and arcs: end points of X Y Z within 2 µm and A B C within 0.002°, after converting rs274's inch output to mm; G53 rows and
axes postproc reports as unknown are not compared; a program with G53 moves is not compared) or say that it did not resolve something (exit
code 1 or 2 with a located PP-U/PP-E code). A program read differently without a word fails the
test. rs274 also prints a zero-length move for a block holding only G0 or G1 (no axis words),
where postproc has no motion: straight moves that end where the previous move ended are dropped
from both lists before comparing. Drilling rows (one per hole) of G81/G82 in the G17 plane are
expanded into the moves rs274 prints for them (expand_drilling); other cycles are not compared.
Prints the counts and every disagreement; exit 1 when a program disagrees silently.
"""
import csv, io, os, re, subprocess, sys, tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rs274_moves  # noqa: E402
from rs274_moves import mm_tool_table  # noqa: E402

def rs274(path, table=None):
    text = rs274_moves.run(path, table, cwd=os.path.dirname(path) or ".", timeout=30)
    if text is None:
        return None
    moves = []
    for name, v, units, plane in rs274_moves.canon(text):
        if name == "error":
            return None  # LinuxCNC stops with an error: not a program it accepts
        if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "STRAIGHT_PROBE"):
            moves.append(("L", [x * units for x in v[:3]] + v[3:6]))
        elif name == "RIGID_TAP":  # G33.1: to the point and back to where it started
            last = moves[-1][1] if moves else [0.0] * 6
            moves.append(("L", [x * units for x in v[:3]] + last[3:6]))
            moves.append(("L", list(last)))
        elif name == "ARC_FEED":
            e = (v[0], v[1], v[5]) if plane == "XY" else (v[1], v[5], v[0]) if plane == "XZ" else (v[5], v[0], v[1])
            moves.append(("A", [x * units for x in e] + v[6:9]))
    return without_zero_length(moves, [0.0] * 6)

def without_zero_length(moves, start):
    """Drops straight moves that end where the previous one ended (None = not known: not compared)."""
    out, last = [], list(start)
    for t, p in moves:
        if t == "L" and any(a is not None for a in p) and all(
                a is None or b is None or abs(a - b) < 1e-6 for a, b in zip(p, last)):
            last = [b if a is None else a for a, b in zip(p, last)]
            continue
        out.append((t, p))
        last = [b if a is None else a for a, b in zip(p, last)]
    return out

def expand_drilling(rows):
    """postproc's rows with G81/G82 holes (one row each) replaced by the moves rs274's
    convert_cycle_xy prints: at the first hole of a block a rise to R when the chain's initial level
    is below it, then per hole a traverse in the plane at the tool's height (the initial level for
    the chain's first hole, the last retract after that), down to R, a feed to the bottom and the
    retract. The initial level is the Z before the first of a chain of cycle rows. Returns None when
    a row is another cycle (pecking, boring) or not in G17. Rows of one block are consecutive rows
    of the same source line."""
    out, last, initial, prev, frame = [], {"x": 0.0, "y": 0.0, "z": 0.0}, None, None, None
    def offsets(r):  # the program origin's shift from the work origin (G52 + G92), and the work system
        return r.get("work_offset"), [float(r.get(f"g52_{a}") or 0) + float(r.get(f"g92_{a}") or 0) for a in "xyz"]
    for r in rows:
        if r["motion"] != "drill":
            out.append(r)
            initial, prev = None, None
            for a in "xyz":
                if r.get(a) not in (None, "") and r.get("frame") != "machine": last[a] = float(r[a])
            frame = offsets(r)
            continue
        if frame is not None and offsets(r) != frame:
            # The position before the cycle in the new program origin (rs274 prints program coordinates).
            if offsets(r)[0] != frame[0]: return None
            for k, a in enumerate("xyz"): last[a] += frame[1][k] - offsets(r)[1][k]
        frame = offsets(r)
        if r.get("cycle") not in ("G81", "G82") or r.get("plane") != "xy" or r.get("frame") == "machine" or \
                any(r.get(k) in (None, "") for k in ("x", "y", "z", "cycle_r", "cycle_bottom")):
            return None
        x, y, z = float(r["x"]), float(r["y"]), float(r["z"])
        rr, bottom = float(r["cycle_r"]), float(r["cycle_bottom"])
        if initial is None: initial = last["z"]
        moves = []
        if prev is None or prev[0] != r["line"]:
            # Each block rises to R when the chain's initial level is below it (rs274 prints the
            # rise even where the tool already is at R); its first traverse is at the tool's height:
            # the initial level, or where the last hole's retract left it.
            old = initial if prev is None else prev[1]
            if initial < rr:
                moves.append((last["x"], last["y"], rr)); old = rr
        else:
            old = prev[1]
        moves.append((x, y, old))
        if old != rr: moves.append((x, y, rr))
        moves += [(x, y, bottom), (x, y, z)]
        for mx, my, mz in moves:
            out.append({**r, "motion": "linear", "x": repr(mx), "y": repr(my), "z": repr(mz)})
        last = {"x": x, "y": y, "z": z}
        prev = (r["line"], z)
    return out

def dump(postproc, path, table=None):
    out = subprocess.run([postproc, "dump", os.path.basename(path), "--dialect", "linuxcnc", "--format", "csv"] +
                         (["--tool-table", table] if table else []),
                         cwd=os.path.dirname(path) or ".", capture_output=True, text=True, timeout=120)
    rows = list(csv.DictReader(io.StringIO(out.stdout))) if out.stdout.startswith("line") else []
    return rows, out.returncode, out.stderr

def main():
    postproc, files = os.path.realpath(sys.argv[1]), sys.argv[2:]
    table = mm_table = None
    if files[:1] == ["--tool-table"]:
        table, files = os.path.abspath(files[1]), files[2:]
        tmp = tempfile.mkdtemp()
        mm_table = os.path.join(tmp, "tools_mm.tbl")
        mm_tool_table(table, mm_table)
    counts = {"agree": 0, "refused or unresolved (located)": 0, "LinuxCNC error": 0, "silent disagreement": 0}
    silent = []
    for f in sorted(files):
        ref = rs274(f, table)
        if ref is None:
            counts["LinuxCNC error"] += 1; continue
        rows, rc, err = dump(postproc, f, mm_table)
        located = rc in (1, 2) and re.search(r":\d+:\d+: (warning|error): PP-[UE]\d+", err)
        if not located and any(r.get("frame") == "machine" for r in rows):
            # G53 rows are machine coordinates in postproc, program coordinates in rs274's output.
            counts["not compared (G53)"] = counts.get("not compared (G53)", 0) + 1
            continue
        expanded = expand_drilling(rows)
        got = [] if expanded is not None else None  # other cycles: rs274 prints each move
        for r in expanded or []:
            if r["motion"] not in ("rapid", "linear", "cw", "ccw"):
                got = None; break
            p = [float(r[a]) if r.get(a) not in (None, "") and r.get("frame") != "machine" else None for a in "xyzabc"]
            got.append(("A" if r["motion"] in ("cw", "ccw") else "L", p))
        if got is not None: got = without_zero_length(got, [0.0] * 6)
        same = got is not None and len(got) == len(ref) and all(
            ta == tb and all(y is None or abs(x - y) <= 2e-3 for x, y in zip(a, b)) for (ta, a), (tb, b) in zip(ref, got))
        if same and rc == 0:
            counts["agree"] += 1
        elif located:
            counts["refused or unresolved (located)"] += 1
        elif got is None and rc == 0:
            counts["not compared (drilling rows)"] = counts.get("not compared (drilling rows)", 0) + 1
        elif same:
            counts["agree"] += 1
        else:
            counts["silent disagreement"] += 1
            silent.append(f"{f}: rs274 {len(ref)} moves, postproc {len(got) if got else 0} (exit {rc})")
    print(", ".join(f"{k}: {v}" for k, v in counts.items()))
    for s in silent: print("SILENT:", s)
    return 1 if silent else 0

if __name__ == "__main__":
    sys.exit(main())
