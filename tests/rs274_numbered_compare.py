#!/usr/bin/env python3
"""Random LinuxCNC programs with Fanuc-style numbered programs through `rs274 -g` and `postproc dump`.

Usage: rs274_numbered_compare.py POSTPROC [FIRST_SEED] [COUNT]

LinuxCNC G-code reference, O codes, "Fanuc-Style Numbered Programs": `M98 P<n> [L<k>]` runs the
numbered program `O<n>` … `M99` k times (L0 is refused: rs274 2.9 does not skip such a call
cleanly, though the reference says it runs nothing), which must come later in the file than
the call (once found, a later call from after it finds it too); #1–#30 are global (not saved
or restored by the call). Each program (fixed seeds) has a main program ending with M30 and up to
four numbered programs after it, each calling only programs placed after it; their bodies hold
absolute and incremental moves, assignments to #1–#30 and to a global, if/else blocks and
repeat loops. A move after each call prints the values, so a pass or a value followed
differently shows up as a move rs274 does not make. Verdicts as tests/rs274_random_compare.py
(agree / located / refused; WRONG fails).
"""
import os, random, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rs274_random_compare as R  # noqa: E402

NAMES = ['#1', '#2', '#30', '#<_g>']


def value(r):
    a, b = r.choice(NAMES), r.choice(NAMES)
    k = r.random()
    if k < 0.4:
        return f'[{a} + {b}]'
    if k < 0.7:
        return f'[{a} * {r.randint(1, 3)} MOD 17]'
    return f'[{a} - {R.f(r.uniform(-3, 3), 2)}]'


def move(r):
    ax = r.sample(['X', 'Y', 'Z'], r.randint(1, 2))
    if r.random() < 0.3:  # incremental, then back to absolute
        return ['G91 G1 ' + ' '.join(f'{a}{R.f(r.uniform(-2, 2), 3)}' for a in ax), 'G90']
    return ['G1 ' + ' '.join(f'{a}[{value(r)} MOD 41]' for a in ax)]


class Gen:
    def __init__(self, r, programs):
        self.r = r
        self.programs = programs  # numbers, in file order
        self.label = 200

    def call(self, after):
        """An M98 line to a program later in the file than program index `after` (-1: main)."""
        r = self.r
        later = self.programs[after + 1:]
        if not later:
            return []
        n = r.choice(later)
        k = r.random()
        # L0 rarely: rs274 2.9 does not skip such a call cleanly, postproc refuses it (PP-E709)
        times = '' if k < 0.4 else ' L0' if k < 0.43 else f' L{r.randint(1, 3)}'
        return [f'M98 P{n}{times}', 'G1 X[#1 MOD 41] Y[#2 MOD 41] Z[#30 MOD 41]']

    def body(self, after, depth):
        r = self.r
        lines = []
        for _ in range(r.randint(1, 4)):
            k = r.random()
            if k < 0.3 or depth <= 0:
                lines += move(r)
            elif k < 0.5:
                lines.append(f'{r.choice(NAMES)} = {value(r)}')
            elif k < 0.75:
                lines += self.call(after) or move(r)
            elif k < 0.88:
                self.label += 1
                n = self.label
                lines.append(f'o{n} if [{r.choice(NAMES)} MOD 3 EQ {r.randint(0, 2)}]')
                lines += self.body(after, depth - 1)
                if r.random() < 0.5:
                    lines.append(f'o{n} else')
                    lines += self.body(after, depth - 1)
                lines.append(f'o{n} endif')
            else:
                self.label += 1
                n = self.label
                lines.append(f'o{n} repeat [{r.randint(0, 3)}]')
                lines += self.body(after, depth - 1)
                lines.append(f'o{n} endrepeat')
        return lines


def program(r):
    count = r.randint(1, 4)
    numbers = sorted(r.sample(range(100, 9000), count))
    if r.random() < 0.5:
        r.shuffle(numbers)  # file order need not follow the numbers
    g = Gen(r, numbers)
    out = ['G21 G17 G90 G94 G40 G49 G80', 'F100', 'G0 X0 Y0 Z10', '#1 = 1', '#2 = 2', '#30 = 3',
           f'#<_g> = {r.randint(0, 9)}']
    out += g.call(-1)
    out += g.body(-1, 2)
    out += g.call(-1)
    out.append('M30')
    for idx, n in enumerate(numbers):
        out.append(f'O{n}')
        out += g.body(idx, 2)
        out.append('M99')
    return '\n'.join(out) + '\n'


def main():
    return R.run_seeds(program, 'rs274_numbered_compare', sys.argv, 200, 0.5)


if __name__ == '__main__':
    sys.exit(main())
