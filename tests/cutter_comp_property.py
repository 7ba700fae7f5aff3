#!/usr/bin/env python3
"""Property test of LinuxCNC cutter radius compensation: random contours (fixed seed) through
LinuxCNC's own interpreter (`rs274 -g`) and `postproc dump`, compared move for move
(tests/rs274_moves.py: straight moves and arcs with centre, direction and turns). A program rs274
refuses must be refused by postproc too (exit 2, a located PP-E error).

Each program: a lead-in, G41 or G42 (tool table radius, or G41.1/G42.1 D), an open or closed
contour of random lines and arcs (I J or R, tangent or not, helices, P turns, some in G91, some with
moves along the normal only or a rapid between them), G40 and a lead-out; G17 or G18 (with lathe tool
orientations: tool table Q, G41.1 L), mm or inch. Radii are mostly smaller than the
features, sometimes not (gouging: refused by both).

Usage: cutter_comp_property.py POSTPROC [--count N] [--seed S] [--keep DIR]
Prints the counts (agree, refused by both) and every difference; exit 1 on any difference.
"""
import argparse, math, os, random, sys, tempfile, time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rs274_moves  # noqa: E402


def fmt(v):
    s = f"{v:.4f}"
    return "0.0000" if s == "-0.0000" else s


class Program:
    def __init__(self, rnd, index):
        self.r = rnd
        self.lines = []
        self.inch = rnd.random() < 0.15
        self.unit = 25.4 if self.inch else 1.0  # mm per program unit
        self.g18 = rnd.random() < 0.2
        # plane letters: (first, second) in-plane axes as LinuxCNC's arcs take them, centre letters
        self.a, self.b = ("Z", "X") if self.g18 else ("X", "Y")
        self.ia, self.ib = ("K", "I") if self.g18 else ("I", "J")
        self.normal = "Y" if self.g18 else "Z"
        self.index = index

    def L(self, mm):  # a length in mm, in program units
        return mm / self.unit

    def emit(self, s):
        self.lines.append(s)


def tool_table():
    # rs274 reads its table in inches: diameters from 0.02" (0.5 mm) to 0.4" (10 mm).
    rows, rnd = [], random.Random(7)
    for t in range(1, 21):
        rows.append(f"T{t} P{t} D{rnd.uniform(0.02, 0.4):.4f} Z0")
    rows.append("T21 P21 D-0.1 Z0")
    # lathe tools (orientation Q), used in G18 programs only
    for t, q in ((22, 1), (23, 2), (24, 3), (25, 4), (26, 5), (27, 6), (28, 7), (29, 8), (30, 9)):
        rows.append(f"T{t} P{t} D{rnd.uniform(0.02, 0.2):.4f} Z0 Q{q}")
    return "\n".join(rows) + "\n"


def make(rnd, index, diameters):
    p = Program(rnd, index)
    u = p.L
    p.emit(f"; random cutter compensation program {index}")
    p.emit(f"{'G20' if p.inch else 'G21'} {'G18' if p.g18 else 'G17'} G90 G94 F{u(600):.4f}")
    use_dynamic = rnd.random() < 0.25
    tool = rnd.randint(22, 30) if p.g18 and rnd.random() < 0.4 else rnd.randint(1, 21)
    if not use_dynamic:
        p.emit(f"T{tool} M6")
        radius_mm = abs(diameters[tool]) * 25.4 / 2
    else:
        radius_mm = rnd.uniform(0.3, 6.0)
    # The contour in mm, in the plane (first, second axis); the program writes it in program units.
    pos = (rnd.uniform(-20, 20), rnd.uniform(-20, 20))
    start = pos
    lead = rnd.uniform(radius_mm * 1.5 + 1, radius_mm * 3 + 20)
    ang = rnd.uniform(0, 2 * math.pi)
    lead_pt = (pos[0] - lead * math.cos(ang), pos[1] - lead * math.sin(ang))
    p.emit(f"G0 {p.a}{fmt(u(lead_pt[0]))} {p.b}{fmt(u(lead_pt[1]))} {p.normal}{fmt(u(5))}")
    p.emit(f"G1 {p.normal}{fmt(u(-1))}")
    side = rnd.choice(["G41", "G42"])
    if use_dynamic:
        comp = f"{side}.1 D{fmt(u(2 * radius_mm))}"
        if p.g18 and rnd.random() < 0.5:
            comp += f" L{rnd.randint(0, 9)}"  # a lathe tool orientation
    else:
        comp = side + (f" D{tool}" if rnd.random() < 0.3 else "")
    # entry: a straight move (sometimes a rapid) or an arc to the first contour point
    if rnd.random() < 0.25:
        # entry arc from lead_pt to pos: a centre on the bisector
        mid = ((lead_pt[0] + pos[0]) / 2, (lead_pt[1] + pos[1]) / 2)
        h = rnd.uniform(-1.5, 1.5) * lead
        nx, ny = -(pos[1] - lead_pt[1]) / lead, (pos[0] - lead_pt[0]) / lead
        c = (mid[0] + h * nx, mid[1] + h * ny)
        g = rnd.choice(["G2", "G3"])
        p.emit(f"{comp} {g} {p.a}{fmt(u(pos[0]))} {p.b}{fmt(u(pos[1]))} "
               f"{p.ia}{fmt(u(c[0] - lead_pt[0]))} {p.ib}{fmt(u(c[1] - lead_pt[1]))}")
        r = math.hypot(pos[0] - c[0], pos[1] - c[1])
        cw = g == "G2"
        rv = (pos[0] - c[0], pos[1] - c[1])
        heading = math.atan2(-rv[0], rv[1]) if not cw else math.atan2(rv[0], -rv[1])
    else:
        move = "G0" if rnd.random() < 0.2 else "G1"
        p.emit(f"{comp} {move} {p.a}{fmt(u(pos[0]))} {p.b}{fmt(u(pos[1]))}")
        heading = ang
    closed = rnd.random() < 0.5
    n = rnd.randint(2, 9)
    incremental = False
    for k in range(n):
        last = k == n - 1 and closed
        # occasional Z-only moves and mode switches between segments
        if rnd.random() < 0.15:
            p.emit(f"G1 {p.normal}{fmt(u(rnd.choice([-1, -2, 0.5])))}")
        want_inc = rnd.random() < 0.2
        if want_inc != incremental:
            p.emit("G91" if want_inc else "G90")
            incremental = want_inc
        kind = "line" if last else rnd.choice(["line", "line", "arc", "arc", "tangent_arc", "tangent_line"])
        if kind in ("line", "tangent_line"):
            if last:
                end = start
            else:
                d = rnd.uniform(max(2 * radius_mm, 3), 40)
                a = heading if kind == "tangent_line" else rnd.uniform(0, 2 * math.pi)
                end = (pos[0] + d * math.cos(a), pos[1] + d * math.sin(a))
            if math.hypot(end[0] - pos[0], end[1] - pos[1]) < 1e-3:
                continue
            g = "G0" if rnd.random() < 0.08 else "G1"
            words = (end[0] - pos[0], end[1] - pos[1]) if incremental else end
            p.emit(f"{g} {p.a}{fmt(u(words[0]))} {p.b}{fmt(u(words[1]))}")
            heading = math.atan2(end[1] - pos[1], end[0] - pos[0])
            pos = end
        else:
            cw = rnd.random() < 0.5
            r = rnd.uniform(max(1.0, radius_mm * rnd.choice([0.5, 1.5, 3])), 30)
            if kind == "tangent_arc":
                # centre to the side the arc turns, at right angles to the heading
                sgn = -1 if cw else 1
                c = (pos[0] + r * math.cos(heading + sgn * math.pi / 2), pos[1] + r * math.sin(heading + sgn * math.pi / 2))
            else:
                a = rnd.uniform(0, 2 * math.pi)
                c = (pos[0] + r * math.cos(a), pos[1] + r * math.sin(a))
            sweep = rnd.uniform(0.3, 5.5) * (-1 if cw else 1)
            a0 = math.atan2(pos[1] - c[1], pos[0] - c[0])
            a1 = a0 + sweep
            end = (c[0] + r * math.cos(a1), c[1] + r * math.sin(a1))
            # write the end and centre rounded, then take them as written
            e_w = (round(u(end[0]), 4), round(u(end[1]), 4))
            c_w = (round(u(c[0] - pos[0]), 4), round(u(c[1] - pos[1]), 4))
            g = "G2" if cw else "G3"
            if incremental:
                ew = (round(u(end[0] - pos[0]), 4), round(u(end[1] - pos[1]), 4))
            else:
                ew = e_w
            # a helix now and then (the normal axis moves), more turns now and then (P)
            extra = f" {p.normal}{fmt(u(rnd.choice([-1.5, -0.5, 0.5])))}" if rnd.random() < 0.15 else ""
            if rnd.random() < 0.3 and abs(sweep) < 2 * math.pi - 0.2:
                rr = u(r) if abs(sweep) <= math.pi else -u(r)
                p.emit(f"{g} {p.a}{fmt(ew[0])} {p.b}{fmt(ew[1])} R{fmt(rr)}{extra}")
            else:
                turns = f" P{rnd.choice([2, 3])}" if rnd.random() < 0.05 else ""
                p.emit(f"{g} {p.a}{fmt(ew[0])} {p.b}{fmt(ew[1])} {p.ia}{fmt(c_w[0])} {p.ib}{fmt(c_w[1])}{extra}{turns}")
            end = (ew[0] * p.unit + (pos[0] if incremental else 0), ew[1] * p.unit + (pos[1] if incremental else 0))
            rv = (end[0] - c[0], end[1] - c[1])
            heading = math.atan2(-rv[0], rv[1]) if not cw else math.atan2(rv[0], -rv[1])
            pos = end
    if incremental:
        p.emit("G90")
    out = rnd.uniform(radius_mm + 2, radius_mm + 20)
    a = rnd.uniform(0, 2 * math.pi)
    p.emit(f"G40 G1 {p.a}{fmt(u(pos[0] + out * math.cos(a)))} {p.b}{fmt(u(pos[1] + out * math.sin(a)))}")
    p.emit(f"G0 {p.normal}{fmt(u(5))}")
    p.emit("M2")
    return "\n".join(p.lines) + "\n"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("postproc")
    ap.add_argument("--count", type=int, default=200)
    ap.add_argument("--seed", type=int, default=20240611)
    ap.add_argument("--keep", help="write the programs (and the tool table) to this folder")
    args = ap.parse_args()
    postproc = os.path.realpath(args.postproc)
    rnd = random.Random(args.seed)
    table = tool_table()
    diameters = {}
    for row in table.splitlines():
        w = row.split()
        diameters[int(w[0][1:])] = float(w[2][1:])
    folder = args.keep or tempfile.mkdtemp()
    os.makedirs(folder, exist_ok=True)
    tbl = os.path.join(folder, "tools.tbl")
    with open(tbl, "w") as f:
        f.write(table)
    counts = {"agree": 0, "refused by both": 0, "differ": 0}
    moves = 0
    t0 = time.time()
    for i in range(args.count):
        text = make(rnd, i, diameters)
        path = os.path.join(folder, f"crc_{i:03d}.ngc")
        with open(path, "w") as f:
            f.write(text)
        ok, msg = rs274_moves.compare(postproc, path, tbl)
        if not ok:
            counts["differ"] += 1
            print(f"DIFFER {os.path.basename(path)}: {msg}")
        elif msg.startswith("refused by both"):
            counts["refused by both"] += 1
        else:
            counts["agree"] += 1
            moves += int(msg.split()[0])
    print(f"cutter_comp_property: {args.count} programs (seed {args.seed}): " +
          ", ".join(f"{k}: {v}" for k, v in counts.items()) + f"; {moves} moves compared; {time.time() - t0:.1f} s")
    if not args.keep:
        for name in os.listdir(folder):
            os.remove(os.path.join(folder, name))
        os.rmdir(folder)
    return 1 if counts["differ"] else 0


if __name__ == "__main__":
    sys.exit(main())
