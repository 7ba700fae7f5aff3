#!/usr/bin/env python3
"""LinuxCNC's own sample programs through LinuxCNC's interpreter (`rs274 -g`) and `postproc dump`.

Usage: lcnc_samples_compare.py POSTPROC [--min-agree N] [--tool-table TOOLS.tbl] FILE.ngc...

With --tool-table, rs274 reads TOOLS.tbl (-t, in inches as rs274 reads its table) and postproc the
same table in mm (--tool-table): the programs under cutter radius compensation are compared for real.
Every rs274 run gets a HOME of its own (rs274 shares its tool table through ~/.tool.mmap with any
rs274 running at the same time).

Per program LinuxCNC runs without an error: postproc must either agree move for move (straight
moves and arcs: end points of X Y Z within 2 µm and A B C within 0.002°, after converting rs274's
inch output to mm; axes postproc reports as unknown are not compared) or say that it did not
resolve something (exit code 1 or 2 with a located PP-U/PP-E code). A program read differently
without a word fails the test. The two lists are paired by agree(): zero-length straight moves may
be left out on either side (rs274 prints one for a block holding only G0 or G1, where postproc has
no motion); a G53 row (machine coordinates in postproc, program coordinates in rs274) stands for
one move of rs274 or none. Drilling rows (one per hole) of G81/G82 in the G17 plane are expanded
into the moves rs274 prints for them (expand_drilling); for G73/G83/G85/G89 the moves at the hole
are checked to reach the bottom and end at the return level; other cycles are not compared.
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
    return moves

def zero_length(moves, start):
    """Per move: True for a straight move that ends where the previous one ended, on every axis the
    move knows (None = not known to postproc: a move from an unknown value is not zero-length)."""
    out, last = [], list(start)
    for t, p in moves:
        out.append(t == "L" and any(a is not None for a in p) and all(
            a is None or (b is not None and abs(a - b) < 1e-6) for a, b in zip(p, last)))
        if t in ("L", "A", "G53"):
            last = list(p)
        elif t == "HOLE":
            last = [p[0], p[1], p[2], None, None, None]
    return out

def agree(ref, got):
    """Move for move: the same kind, every axis postproc knows within 2 µm (0.002°). Zero-length
    straight moves may be left out on either side (rs274 prints one for a block holding only G0 or
    G1, where postproc has no motion). A "G53" row of postproc (machine coordinates; rs274 prints
    program coordinates) stands for one move of rs274 or none; a "HOLE" (G73/G83 pecks, G85/G89)
    for rs274's moves at its X Y, the deepest at the bottom, the last at the level the cycle returns
    to. A search over the ways to pair the two lists (depth first, pairing tried first)."""
    def same(a, b):
        return a[0] == b[0] and all(y is None or abs(x - y) <= 2e-3 for x, y in zip(a[1], b[1]))
    n, m = len(ref), len(got)
    ref_zero, got_zero = zero_length(ref, [0.0] * 6), zero_length(got, [0.0] * 6)
    stack, seen = [(0, 0)], set()
    while stack:
        i, j = stack.pop()
        if (i, j) in seen:
            continue
        seen.add((i, j))
        if i == n and j == m:
            return True
        if j < m and got_zero[j]:
            stack.append((i, j + 1))
        if i < n and ref_zero[i]:
            stack.append((i + 1, j))
        if j >= m:
            continue
        kind, p = got[j]
        if kind == "G53":
            stack.append((i, j + 1))
            if i < n:
                stack.append((i + 1, j + 1))
        elif kind == "HOLE":
            x, y, z, bottom = p
            k = i
            while k < n and ref[k][0] == "L" and abs(ref[k][1][0] - x) <= 2e-3 and abs(ref[k][1][1] - y) <= 2e-3:
                k += 1
            # the hole may end before the last of these (a G53 move after it stays at X Y)
            low = float("inf")
            for e in range(i, k):
                low = min(low, ref[e][1][2])
                if e > i and abs(low - bottom) <= 2e-3 and abs(ref[e][1][2] - z) <= 2e-3:
                    stack.append((e + 1, j + 1))
        elif i < n and same(ref[i], got[j]):
            stack.append((i + 1, j + 1))
    return False

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
        if r.get("cycle") not in ("G81", "G82", "G73", "G83", "G85", "G89") or r.get("plane") != "xy" or r.get("frame") == "machine" or \
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
        pecks = r["cycle"] not in ("G81", "G82")
        if not pecks:
            moves += [(x, y, bottom), (x, y, z)]
        for mx, my, mz in moves:
            out.append({**r, "motion": "linear", "x": repr(mx), "y": repr(my), "z": repr(mz)})
        if pecks:  # the moves at the hole are checked by agree(): down to the bottom, ending at z
            out.append({**r, "motion": "hole", "x": repr(x), "y": repr(y), "z": repr(z), "bottom": bottom})
        last = {"x": x, "y": y, "z": z}
        prev = (r["line"], z)
    return out

def moves_of(rows):
    """postproc's dump rows as the moves agree() pairs with rs274's: ("L" | "A" | "G53" | "HOLE",
    values); None where a row cannot be compared (a cycle expand_drilling does not expand)."""
    expanded = expand_drilling(rows)
    if expanded is None:
        return None
    got = []
    for r in expanded:
        if r["motion"] == "hole":
            got.append(("HOLE", [float(r["x"]), float(r["y"]), float(r["z"]), r["bottom"]]))
            continue
        if r["motion"] not in ("rapid", "linear", "cw", "ccw"):
            return None
        p = [float(r[a]) if r.get(a) not in (None, "") and r.get("frame") != "machine" else None for a in "xyzabc"]
        got.append(("G53" if r.get("frame") == "machine" else "A" if r["motion"] in ("cw", "ccw") else "L", p))
    return got

def dump(postproc, path, table=None):
    out = subprocess.run([postproc, "dump", os.path.basename(path), "--dialect", "linuxcnc", "--format", "csv"] +
                         (["--tool-table", table] if table else []),
                         cwd=os.path.dirname(path) or ".", capture_output=True, text=True, timeout=120)
    rows = list(csv.DictReader(io.StringIO(out.stdout))) if out.stdout.startswith("line") else []
    return rows, out.returncode, out.stderr

def main():
    postproc, files = os.path.realpath(sys.argv[1]), sys.argv[2:]
    table = mm_table = None
    min_agree = 0
    if files[:1] == ["--min-agree"]:
        min_agree, files = int(files[1]), files[2:]
    if files[:1] == ["--tool-table"]:
        table, files = os.path.abspath(files[1]), files[2:]
        tmp = tempfile.mkdtemp()
        mm_table = os.path.join(tmp, "tools_mm.tbl")
        mm_tool_table(table, mm_table)
    counts = {"agree": 0, "refused or unresolved (located)": 0, "LinuxCNC error": 0, "silent disagreement": 0}
    silent, located_list, not_compared = [], [], []
    for f in sorted(files):
        ref = rs274(f, table)
        if ref is None:
            counts["LinuxCNC error"] += 1; continue
        rows, rc, err = dump(postproc, f, mm_table)
        located = rc in (1, 2) and re.search(r":\d+:\d+: (warning|error): PP-[UE]\d+", err)
        got = moves_of(rows)
        same = got is not None and agree(ref, got)
        if same and rc == 0:
            counts["agree"] += 1
        elif located:
            counts["refused or unresolved (located)"] += 1
            first = re.search(r"\S+:\d+:\d+: (warning|error): PP-[UE]\d+[^\n]*", err)
            located_list.append(f"{os.path.basename(f)} (moves {'agree' if same else 'differ'}): {first.group(0)[:160]}")
        elif got is None and rc == 0:
            counts["not compared (drilling rows)"] = counts.get("not compared (drilling rows)", 0) + 1
        elif same:
            counts["agree"] += 1
        else:
            counts["silent disagreement"] += 1
            silent.append(f"{f}: rs274 {len(ref)} moves, postproc {len(got) if got else 0} (exit {rc})")
    print(", ".join(f"{k}: {v}" for k, v in counts.items()))
    for s in located_list: print("located:", s)
    for s in not_compared: print("not compared (G53):", s)
    for s in silent: print("SILENT:", s)
    if counts["agree"] < min_agree:
        print(f"FAIL: {counts['agree']} programs agree, fewer than the {min_agree} this version reached")
        return 1
    return 1 if silent else 0

if __name__ == "__main__":
    sys.exit(main())
