#!/usr/bin/env python3
"""Threading cycles (docs/threading.md) against LinuxCNC's own interpreter, move for move.

Usage: threading_compare.py POSTPROC FILE.ngc...

Each program is run through `rs274 -g` (no tool table; a HOME of its own, rs274_moves.run) and through
`postproc dump --dialect linuxcnc`. The straight moves must agree one to one: STRAIGHT_TRAVERSE is a
rapid, STRAIGHT_FEED a linear move; X Y Z end points within 6e-5 program units (rs274 prints 4
decimals; inch output is converted to mm); a feed move made while rs274 has speed-feed
synchronisation on (START_SPEED_FEED_SYNC(pitch, 0) ... STOP_SPEED_FEED_SYNCH) must be feed per
revolution at that pitch (6 printed decimals). Arcs are not part of these programs' threading and
are skipped on both sides. Exit 1 on the first difference of each program.
"""
import csv, io, os, subprocess, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rs274_moves  # noqa: E402


def rs274(path):
    moves, sync = [], None
    for name, v, units, _ in rs274_moves.canon(rs274_moves.run(path, cwd=os.path.dirname(path) or ".") or "timeout"):
        if name == "error":
            return moves, v  # rs274 stopped with an error
        if name == "START_SPEED_FEED_SYNC":
            sync = v[0] * units
        elif name == "STOP_SPEED_FEED_SYNCH":
            sync = None
        elif name == "RIGID_TAP":  # G33.1: to the point and back, both synchronised
            last = moves[-1][1] if moves else [0.0, 0.0, 0.0]
            moves.append(("linear", [x * units for x in v[:3]], sync, units))
            moves.append(("linear", list(last), sync, units))
        elif name in ("STRAIGHT_FEED", "STRAIGHT_TRAVERSE"):
            feed = name == "STRAIGHT_FEED"
            moves.append(("linear" if feed else "rapid", [x * units for x in v[:3]], sync if feed else None, units))
    return moves, None


def dump(postproc, path):
    out = subprocess.run([postproc, "dump", os.path.basename(path), "--dialect", "linuxcnc", "--format", "csv"],
                         cwd=os.path.dirname(path) or ".", capture_output=True, text=True, timeout=60)
    rows = list(csv.DictReader(io.StringIO(out.stdout))) if out.stdout.startswith("line") else []
    got, last = [], [0.0, 0.0, 0.0]
    for r in rows:
        if r["motion"] not in ("rapid", "linear"):
            continue
        for k, a in enumerate("xyz"):
            if r.get(a) not in (None, "", "null"):
                last[k] = float(r[a])
        feed = float(r["feed"]) if r.get("feed") not in (None, "") else None
        got.append((r["motion"], list(last), feed, r["feed_mode"], int(r["line"])))
    return got, out.stderr


def main():
    postproc, fails = sys.argv[1], 0
    for path in sys.argv[2:]:
        name = os.path.basename(path)
        ref, error = rs274(path)
        if error:
            print(f"FAIL: {name}: rs274 stops: {error}")
            fails += 1
            continue
        got, err = dump(postproc, path)
        if "PP-U202" in err or "PP-E" in err:
            print(f"FAIL: {name}: postproc refuses threading: {err.strip().splitlines()[0]}")
            fails += 1
            continue
        if len(ref) != len(got):
            print(f"FAIL: {name}: rs274 {len(ref)} straight moves, postproc {len(got)}")
            fails += 1
            continue
        bad = None
        for i, ((kind, xyz, sync, units), (gkind, gxyz, gfeed, gmode, line)) in enumerate(zip(ref, got)):
            if kind != gkind or any(abs(a - b) > 6e-5 * units for a, b in zip(xyz, gxyz)):
                bad = f"move {i + 1} (line {line}): rs274 {kind} {xyz}, postproc {gkind} {gxyz}"
            elif sync is not None and (gmode != "per_rev" or gfeed is None or abs(gfeed - abs(sync)) > 1e-6 * units):
                bad = f"move {i + 1} (line {line}): rs274 synchronised at {sync} per revolution, postproc {gfeed} {gmode}"
            if bad:
                break
        if bad:
            print(f"FAIL: {name}: {bad}")
            fails += 1
        else:
            print(f"{name}: {len(ref)} moves agree with rs274")
    sys.exit(1 if fails else 0)


if __name__ == "__main__":
    main()
