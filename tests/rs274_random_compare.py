#!/usr/bin/env python3
"""Random LinuxCNC programs through LinuxCNC's interpreter (`rs274 -g`) and `postproc dump`.

Usage: rs274_random_compare.py POSTPROC [FIRST_SEED] [COUNT]

Each program (fixed seeds, so a failure is repeatable) mixes what the reader must follow exactly:
G20/G21, G90/G91, G90.1/G91.1, the three planes, straight moves of X Y Z A B C, arcs by centre and
by radius (helical too), G92 / G92.1 / G92.2 / G92.3, G52, G10 L2 (with rotation) and G10 L20, G7/G8,
G43.1/G49, G93/G94, drilling cycles G81/G82 under G98/G99, parameters and o-word loops, M70/M72.
Per program, one of:
  agree       the same moves as rs274 (tests/lcnc_samples_compare.py compares them);
  unknown     postproc leaves a position unknown (G10 L2 writes a table entry it does not know, …)
              and shows it blank;
  located     postproc says it did not resolve something (exit 1/2 and a located PP-U/PP-E);
  refused     rs274 stops with an error and postproc refuses the program too (exit 2, located), or
              says where it lost track of a position before the block rs274 stops at (exit 1).
A program read differently without a word, or accepted where rs274 stops, fails the test.
"""
import math, os, random, re, subprocess, sys, tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import lcnc_samples_compare as L  # noqa: E402


def f(v, nd=4):
    s = f"{v:.{nd}f}".rstrip('0').rstrip('.')
    return s if s not in ('', '-0') else '0'


def arc_incremental(r, plane, s):
    """An arc in G91 from wherever the tool is: centre offset and end on the circle."""
    u, v = {'G17': 'XY', 'G18': 'ZX', 'G19': 'YZ'}[plane]
    letter = {'X': 'I', 'Y': 'J', 'Z': 'K'}
    rad = r.uniform(1, 15) * s
    a0 = r.uniform(0, 2 * math.pi)
    cu, cv = -rad * math.cos(a0), -rad * math.sin(a0)
    sweep = r.uniform(0.1, 2 * math.pi - 0.1)
    g = r.choice(['G2', 'G3'])
    a1 = a0 + (-1 if g == 'G2' else 1) * sweep
    w = [g, f'{u}{f(cu + rad * math.cos(a1))}', f'{v}{f(cv + rad * math.sin(a1))}']
    if r.random() < 0.5:
        w += [f'{letter[u]}{f(cu)}', f'{letter[v]}{f(cv)}']
    else:
        w.append(f'R{f(rad if sweep <= math.pi else -rad)}')
    if r.random() < 0.3:
        w.append(f"{'XYZ'.replace(u, '').replace(v, '')}{f(r.uniform(-3, 3) * s)}")
    return ' '.join(w)


def program(r):
    inch = r.random() < 0.25
    s = 1 / 25.4 if inch else 1.0
    out = ['G20' if inch else 'G21', 'G17 G90 G94 G40 G49 G80 G91.1',
           f'G0 X{f(r.uniform(-50, 50) * s)} Y{f(r.uniform(-50, 50) * s)} Z{f(r.uniform(5, 20) * s)} A0 B0 C0', 'F100']
    plane = 'G17'

    def settle():  # a move after a position change that has no move of its own (the comparison needs one)
        out.extend(['G90', f'G0 Z{f(r.uniform(5, 20) * s)}'])

    for k in range(r.randint(6, 30)):
        x = r.random()
        motions = [m for line in out for m in re.findall(r'\bG([0-3])(?![.0-9])', line)]
        modal_arc = bool(motions) and motions[-1] in '23'
        if x < 0.04:
            plane = r.choice(['G17', 'G18', 'G19'])
            out.append(plane)
        elif x < 0.06:  # another work system: known when G10 L2 wrote it (P1-P3 below), else blank
            out.append(r.choice(['G54', 'G55', 'G56', 'G57', 'G59.3']))
            settle()
        elif x < 0.10:
            out.append(f'G92 X{f(r.uniform(-20, 20) * s)} Y{f(r.uniform(-20, 20) * s)}' +
                       (f' Z{f(r.uniform(-5, 5) * s)}' if r.random() < .5 else ''))
            settle()
        elif x < 0.13:
            out.append(r.choice(['G92.1', 'G92.2', 'G92.3']))
            settle()
        elif x < 0.16:
            out.append(f'G52 X{f(r.uniform(-20, 20) * s)} Y{f(r.uniform(-20, 20) * s)}')
            settle()
        elif x < 0.19:
            out.append(f'G10 L2 P{r.randint(1, 3)} X{f(r.uniform(-30, 30) * s)} Y{f(r.uniform(-30, 30) * s)}' +
                       (f' R{f(r.uniform(-45, 45), 2)}' if r.random() < .6 else ''))
        elif x < 0.22:
            out.append(f'G10 L20 P1 X{f(r.uniform(-30, 30) * s)}' + (f' Z{f(r.uniform(-3, 3) * s)}' if r.random() < .5 else ''))
            settle()
        elif x < 0.25:
            out.append(f'#{r.randint(1, 5)} = [{f(r.uniform(-10, 10))} * {f(r.uniform(0, 3))} + {f(r.uniform(-5, 5))}]')
        elif x < 0.29:
            out.append(f'G43.1 Z{f(r.uniform(-5, 5) * s)}' if r.random() < .7 else 'G49')
            settle()
        elif x < 0.295:
            # A trap: I J K as the centre's coordinates; the arc is refused unless it happens to close.
            out.extend(['G90.1', 'G91', arc_incremental(r, plane, s), 'G90', 'G91.1'])
        elif x < 0.52:
            inc = r.random() < 0.4
            out.append('G91' if inc else 'G90')
            w = [r.choice(['G0', 'G1'] if modal_arc else ['G0', 'G1', ''])]  # a modal G2/G3 needs centre words
            axes = r.sample('XYZABC', r.randint(1, 3))
            for a in axes:
                w.append(f'{a}{f(r.uniform(-90, 90), 3)}' if a in 'ABC' else
                         f'{a}{f(r.uniform(-10, 10) * s if inc else r.uniform(-50, 50) * s)}')
            free = [a for a in 'XYZ' if a not in axes]
            if free and r.random() < 0.1:
                w.append(f'{free[0]}#{r.randint(1, 5)}')
            out.append(' '.join(t for t in w if t))
        elif x < 0.72:
            out.extend(['G91', arc_incremental(r, plane, s), 'G90'])
        elif x < 0.80:
            settle()
            plane = 'G17'
            out.append('G17')
            out.append(f'{r.choice(["G98", "G99"])} {r.choice(["G81", "G82 P0.5"])} X{f(r.uniform(-40, 40) * s)} '
                       f'Y{f(r.uniform(-40, 40) * s)} Z{f(r.uniform(-5, 0) * s)} R{f(r.uniform(0.5, 3) * s)}')
            if r.random() < .5:
                out.append(f'X{f(r.uniform(-40, 40) * s)}')
            out.extend(['G80', 'G90', f'G0 X{f(r.uniform(-40, 40) * s)} Y{f(r.uniform(-40, 40) * s)}'])
        elif x < 0.86:
            out.extend(['#10 = 0', f'o{100 + k} while [#10 LT {r.randint(1, 3)}]', 'G91',
                        f'G1 X{f(r.uniform(-3, 3) * s)} Y{f(r.uniform(-3, 3) * s)}', 'G90', '#10 = [#10 + 1]',
                        f'o{100 + k} endwhile'])
        elif x < 0.90:
            out.append(r.choice(['M70', 'M72' if 'M70' in out else 'M70', 'G61', 'G64 P0.01', 'G61.1', 'G64']))
        elif x < 0.93:
            out.extend([f'G93 G1 X{f(r.uniform(-40, 40) * s)} F{f(r.uniform(1, 20))}', 'G94 F100'])
        elif x < 0.95:  # G33.1 rigid tapping: to the point and back (a slanted one too)
            tap = f'G33.1 Z{f(r.uniform(-8, 0) * s)} K{f(r.uniform(0.5, 2) * s)}'
            if r.random() < .3:
                tap = f'G33.1 X{f(r.uniform(-40, 40) * s)} Z{f(r.uniform(-8, 0) * s)} K{f(r.uniform(0.5, 2) * s)}'
            out.extend(['M3 S500', r.choice(['', 'G93 ', 'G91 ']) + tap, 'G94 G90 F100', 'M5'])
        else:
            out.append(r.choice(['G7', 'G8']))
            settle()
    out.append('M2')
    return '\n'.join(out) + '\n'


def judge(postproc, path):
    ref = L.rs274(path)
    rows, rc, err = L.dump(postproc, path)
    located = rc in (1, 2) and re.search(r":\d+:\d+: (warning|error): PP-[UE]\d+", err)
    if ref is None:
        # Refused, or a located warning that a position was not known (the error lay beyond it).
        return ('refused', '') if located else ('WRONG', f'rs274 stops with an error, postproc exit {rc}')
    got = L.moves_of(rows)
    if got is None:
        return 'WRONG', 'a row the comparison cannot pair (a cycle it does not expand)'
    if any(c is None for kind, p in got if kind in ('L', 'A') for c in p[:3]):
        return 'unknown', ''
    same = L.agree(ref, got)
    if same:
        return 'agree', ''
    if located:
        return 'located', err.strip().splitlines()[0]
    return 'WRONG', f'rs274 {len(ref)} moves, postproc {len(got)} (exit {rc})'


def run_seeds(program_of, module, argv, default_count, min_agree_share):
    """Writes program_of(random.Random(seed)) for each seed, judges it (judge()), prints the counts
    and every WRONG with the command that regenerates it; exit status 1 on a WRONG or when fewer
    than min_agree_share of the programs were compared move for move."""
    postproc = os.path.realpath(argv[1])
    first = int(argv[2]) if len(argv) > 2 else 1
    count = int(argv[3]) if len(argv) > 3 else default_count
    counts, wrong = {}, []
    with tempfile.TemporaryDirectory() as d:
        for seed in range(first, first + count):
            path = os.path.join(d, f'p{seed}.ngc')
            with open(path, 'w') as fh:
                fh.write(program_of(random.Random(seed)))
            verdict, why = judge(postproc, path)
            counts[verdict] = counts.get(verdict, 0) + 1
            if verdict == 'WRONG':
                wrong.append((seed, why))
    print(', '.join(f'{k}: {v}' for k, v in sorted(counts.items())))
    for seed, why in wrong:
        print(f'WRONG seed {seed}: {why} (regenerate: python3 -c "import random,sys; sys.path.insert(0, \'tests\'); '
              f'import {module} as M; print(M.program(random.Random({seed})), end=\'\')")')
    if counts.get('agree', 0) < count * min_agree_share:
        print(f'FAIL: fewer than {min_agree_share:.0%} of the programs were compared move for move')
        return 1
    return 1 if wrong else 0


def main():
    return run_seeds(program, 'rs274_random_compare', sys.argv, 250, 0.25)


if __name__ == '__main__':
    sys.exit(main())
