#!/usr/bin/env python3
"""LinuxCNC lathe profile cycles on random profiles: `postproc dump` against LinuxCNC's own
interpreter (`rs274 -g`), move for move (tests/rs274_moves.py: end points, arc centres and
directions), or both refusing the program.

Each seed makes one program: a profile of 3 to 7 blocks running towards -Z and +X (straights along
Z, along X, oblique; G2/G3 arcs by R), half of the corners with an A (fillet) or C (chamfer) word,
and one of G70 (D, E, P passes), G71, G71.1, G71.2 (after a G71.1), G72, G72.1, G72.2 from a start
beside the profile. Many of them rs274 refuses ("Not monotonic", "Cannot intersect parallel lines",
arcs whose offset radii differ): postproc must refuse those too, located. A program rs274 crashes on
(segmentation fault in its G7x code) counts as refused by LinuxCNC.

Usage: lathe_random_compare.py POSTPROC FIRST_SEED LAST_SEED. Exit 1 on any disagreement.
"""
import os, random, sys, tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rs274_moves  # noqa: E402


def profile(r):
    x, z = r.uniform(0, 3), r.uniform(-1, 1)
    lines = [f"G1 X{x:.3f} Z{z:.3f}"]
    n = r.randint(2, 6)
    for k in range(n):
        kind = r.random()
        if kind < 0.35:
            z -= r.uniform(1, 6)
            blk = f"G1 Z{z:.3f}"
        elif kind < 0.6:
            x += r.uniform(0.5, 3)
            blk = f"G1 X{x:.3f}"
        elif kind < 0.8:
            x, z = x + r.uniform(0.5, 3), z - r.uniform(0.5, 4)
            blk = f"G1 X{x:.3f} Z{z:.3f}"
        else:
            dx, dz = r.uniform(0.5, 3), r.uniform(0.5, 4)
            rad = (dx * dx + dz * dz) ** 0.5 / 2 * r.uniform(1.05, 2.5)
            x, z = x + dx, z - dz
            blk = f"{r.choice(['G2', 'G3'])} X{x:.3f} Z{z:.3f} R{rad:.3f}"
        if k < n - 1 and r.random() < 0.5:
            blk += f" {r.choice('AC')}{r.uniform(0.1, 0.8):.3f}"
        lines.append(blk)
    return lines, x


def program(seed):
    r = random.Random(seed)
    prof, x_end = profile(r)
    cycle = r.choice(["G70", "G71", "G71.1", "G71.2", "G72", "G72.1", "G72.2"])
    sx, sz = x_end + r.uniform(0.5, 3), r.uniform(1.5, 4)
    out = ["G18 G21 G90 G40 F400", "O100 SUB"] + ["  " + line for line in prof] + ["O100 ENDSUB",
                                                                                 f"G0 X{sx:.3f} Z{sz:.3f}"]
    if cycle == "G70":
        out.append(f"G70 Q100 X{sx:.3f} Z{sz:.3f} D{r.uniform(0, 1):.2f} E{r.uniform(0, 0.3):.2f} P{r.randint(1, 3)}")
    else:
        if cycle.endswith(".2"):
            out.append(f"{cycle[:3]}.1 Q100 X{sx:.3f} Z{sz:.3f} D0.3 I{r.uniform(0.3, 1.5):.2f} R0.3")
        out.append(f"{cycle} Q100 X{sx:.3f} Z{sz:.3f} D{r.uniform(0, 0.5):.2f} I{r.uniform(0.3, 1.5):.2f} "
                   f"R{r.uniform(0.1, 0.5):.2f}")
    out.append("M2")
    return "\n".join(out) + "\n", cycle


def main():
    postproc, first, last = os.path.realpath(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    counts, bad = {}, []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(first, last + 1):
            text, cycle = program(seed)
            path = os.path.join(tmp, f"lathe_{seed}.ngc")
            with open(path, "w") as f:
                f.write(text)
            ok, msg = rs274_moves.compare(postproc, path, None)
            kind = "refused by both" if msg.startswith("refused by both") else "agree" if ok else "DISAGREE"
            counts[kind] = counts.get(kind, 0) + 1
            if not ok:
                bad.append(f"seed {seed} ({cycle}): {msg}\n{text}")
    print(", ".join(f"{k}: {v}" for k, v in sorted(counts.items())))
    for b in bad:
        print("FAIL:", b)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
