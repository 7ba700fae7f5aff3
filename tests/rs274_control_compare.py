#!/usr/bin/env python3
"""Random LinuxCNC O-word programs through LinuxCNC's interpreter (`rs274 -g`) and `postproc dump`.

Usage: rs274_control_compare.py POSTPROC [FIRST_SEED] [COUNT]

Each program (fixed seeds, so a failure is repeatable) nests the control flow of the LinuxCNC
G-code reference ("O Codes"): subroutines with arguments (#1–#30 local to the call), named locals
and globals, `return [value]` read back as #<_value> / #<_value_returned>, calls from subroutines;
`while` / `do … while` / `repeat` loops with `break` and `continue`; `if` / `elseif` / `else`. A
move after every step prints the counters and values, so a branch, a pass or a value read
differently shows up as a move rs274 does not make. Verdicts as tests/rs274_random_compare.py
(agree / located / refused; WRONG fails).
"""
import os, random, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rs274_random_compare as R  # noqa: E402


class Gen:
    def __init__(self, r):
        self.r = r
        self.label = 100
        self.out = []
        self.subs = []
        self.loop_vars = 0

    def next_label(self):
        self.label += 1
        return self.label

    def value(self, names):
        r = self.r
        a = r.choice(names)
        k = r.random()
        if k < 0.3:
            return f'[{a} * {r.randint(1, 4)} MOD 37]'
        if k < 0.6:
            return f'[{a} + {r.choice(names)}]'
        return f'[{a} - {R.f(r.uniform(-5, 5), 2)}]'

    def move(self, names, indent):
        r = self.r
        ax = r.sample(['X', 'Y', 'Z'], r.randint(1, 2))
        return indent + 'G1 ' + ' '.join(f'{a}[{self.value(names)} MOD 97]' for a in ax)

    def block(self, names, depth, indent, in_loop, in_sub):
        """A list of lines: moves, assignments and nested control flow."""
        r = self.r
        lines = []
        for _ in range(r.randint(1, 4)):
            k = r.random()
            if k < 0.3 or depth <= 0:
                lines.append(self.move(names, indent))
            elif k < 0.42:
                t = r.choice([n for n in names if not n.startswith('#<_value')] or ['#<_g>'])
                if t.startswith('#') and t[1:].isdigit() and in_sub and int(t[1:]) <= 30:
                    pass  # an argument: assigning it is fine (local to the call)
                lines.append(f'{indent}{t} = {self.value(names)}')
            elif k < 0.55:
                n = self.next_label()
                cond = f'[{r.choice(names)} MOD {r.randint(2, 4)} {r.choice(["EQ", "NE", "GT", "LT"])} {r.randint(0, 2)}]'
                lines.append(f'{indent}o{n} if {cond}')
                lines += self.block(names, depth - 1, indent + '  ', in_loop, in_sub)
                if r.random() < 0.4:
                    lines.append(f'{indent}o{n} elseif [{r.choice(names)} GT {r.randint(-5, 20)}]')
                    lines += self.block(names, depth - 1, indent + '  ', in_loop, in_sub)
                if r.random() < 0.5:
                    lines.append(f'{indent}o{n} else')
                    lines += self.block(names, depth - 1, indent + '  ', in_loop, in_sub)
                lines.append(f'{indent}o{n} endif')
            elif k < 0.72:
                n = self.next_label()
                self.loop_vars += 1
                v = f'#<i{self.loop_vars}>' if in_sub else f'#<_i{self.loop_vars}>'
                limit = r.randint(1, 4)
                kind = r.choice(['while', 'do', 'repeat'])
                inner_names = names + [v]
                body = self.block(inner_names, depth - 1, indent + '  ', True, in_sub)
                if r.random() < 0.35:  # a break or continue under a condition
                    m = self.next_label()
                    body.append(f'{indent}  o{m} if [{v} EQ {r.randint(0, limit)}]')
                    body.append(f'{indent}    o{n} {r.choice(["break", "continue"])}')
                    body.append(f'{indent}  o{m} endif')
                    body.append(self.move(inner_names, indent + '  '))
                lines.append(f'{indent}{v} = 0')
                step = f'{indent}  {v} = [{v} + 1]'
                if kind == 'while':
                    lines.append(f'{indent}o{n} while [{v} LT {limit}]')
                    lines.append(step)  # counted first: a continue cannot skip it
                    lines += body
                    lines.append(f'{indent}o{n} endwhile')
                elif kind == 'do':
                    lines.append(f'{indent}o{n} do')
                    lines.append(step)
                    lines += body
                    lines.append(f'{indent}o{n} while [{v} LT {limit}]')
                else:
                    # rs274 rounds the count to the nearest integer, ties to even (no extra random
                    # draw: the programs of the other seeds stay as they were)
                    count = (f'{limit}', f'{limit - 1}.5', f'{limit}.4')[n % 3]
                    lines.append(f'{indent}o{n} repeat [{count}]')
                    lines.append(step)
                    lines += body
                    lines.append(f'{indent}o{n} endrepeat')
            elif self.subs:
                name, nargs = r.choice(self.subs)
                args = ' '.join(f'[{self.value(names)}]' for _ in range(r.randint(0, nargs)))
                lines.append(f'{indent}o<{name}> call {args}'.rstrip())
                lines.append(f'{indent}G1 X[#<_value> MOD 97] Y[#<_value_returned> * 7]')
            else:
                lines.append(self.move(names, indent))
        return lines

    def sub(self, name, nargs):
        r = self.r
        names = [f'#{i}' for i in range(1, nargs + 1)] + ['#<_g>', '#<loc>']
        lines = [f'o<{name}> sub', f'  #<loc> = [#1 + {r.randint(1, 5)}]']
        lines += self.block(names, 2, '  ', False, True)
        if r.random() < 0.6:
            m = self.next_label()
            lines.append(f'  o{m} if [#<loc> GT {r.randint(0, 10)}]')
            lines.append(f'    o<{name}> return [#<loc> * {r.randint(1, 3)}]')
            lines.append(f'  o{m} endif')
        lines.append(f'o<{name}> endsub')
        return lines


def program(r):
    g = Gen(r)
    out = ['G21 G17 G90 G94 G40 G49 G80', 'F100', 'G0 X0 Y0 Z10', f'#<_g> = {r.randint(0, 9)}',
           f'#1 = {r.randint(0, 9)}']
    for k in range(r.randint(0, 3)):
        name = f's{k}'
        nargs = r.randint(1, 3)
        out += g.sub(name, nargs)
        g.subs.append((name, nargs))
    out += g.block(['#<_g>', '#1'], 3, '', False, False)
    out.append('M2')
    return '\n'.join(out) + '\n'


def main():
    return R.run_seeds(program, 'rs274_control_compare', sys.argv, 200, 0.5)


if __name__ == '__main__':
    sys.exit(main())
