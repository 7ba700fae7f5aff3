#!/usr/bin/env python3
"""Random LinuxCNC expressions through LinuxCNC's interpreter (`rs274 -g`) and `postproc dump`.

Usage: rs274_expression_compare.py POSTPROC [FIRST_SEED] [COUNT]

Each program (fixed seeds, so a failure is repeatable) assigns random expressions to numbered and
named parameters and moves to random expressions, so that every value the reader computes shows up
in a position rs274 prints. What is drawn (LinuxCNC G-code reference, "Expressions", "Binary
operators", "Functions", "Parameters"):
  - binary operators of every precedence class in one bracket without inner brackets (** first,
    then * / MOD, then + -, then EQ NE GT GE LT LE, then AND OR XOR), left to right within a class;
  - unary functions ABS ACOS ASIN COS EXP FIX FUP LN ROUND SIN SQRT TAN and ATAN[a]/[b], unary minus
    and plus on numbers, parameters and brackets;
  - values where only rs274's exact rules give its answer (EXACT: trigonometry in long double, EQ
    and NE within 0.0001, ROUND as (int)(x ± 0.5));
  - several assignments on one line (all are evaluated before any is set) and a move on the line of
    an assignment (it uses the value before the line);
  - arguments outside a function's domain (SQRT of a negative, LN of 0, ACOS of 2, division by 0):
    rs274 stops there, and postproc must refuse the program too, located.
Verdicts as tests/rs274_random_compare.py (agree / located / refused; WRONG fails). The moves are
compared within 2 µm, so values are scaled to stay within a few hundred mm.
"""
import os, random, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rs274_random_compare as R  # noqa: E402

FUNCS = ['ABS', 'ACOS', 'ASIN', 'COS', 'EXP', 'FIX', 'FUP', 'LN', 'ROUND', 'SIN', 'SQRT', 'TAN']
OPS = ['+', '-', '*', '/', 'MOD', '**', 'AND', 'OR', 'XOR', 'EQ', 'NE', 'GT', 'GE', 'LT', 'LE']


def number(r):
    k = r.random()
    if k < 0.3:
        return str(r.randint(-5, 9))
    if k < 0.5:
        return R.f(r.uniform(-1, 1), 3)
    return R.f(r.uniform(-9, 9), r.choice([1, 2, 4]))


# Values where double arithmetic and rs274's differ unless the rules are followed exactly:
# trigonometry in long double (SIN[30] is 0.5, ACOS[0.5] is 60, TAN[45] is 1), EQ / NE within
# 0.0001, ROUND as (int)(x ± 0.5).
EXACT = ['FIX[SIN[30] * 2]', 'FIX[COS[60] * 10]', 'FUP[ACOS[0.5] / 60]', 'FIX[TAN[45]]', 'FIX[ASIN[0.5] / 30]',
         'ROUND[0.49999999999999994]', 'ROUND[-0.49999999999999994]', '[1 EQ 1.00005]', '[1 NE 0.99991]',
         '[2.5 EQ 2.5001]', '[0 EQ 0.0001]', 'FIX[ATAN[1]/[SQRT[3]] / 30]', 'FIX[SIN[150] * 2]']


def leaf(r, params):
    k = r.random()
    if k < 0.08:
        e = r.choice(EXACT)
        return e.replace('1.00005', f'[{r.choice(params)} * 0 + 1.00005]') if params and r.random() < .3 else e
    if k < 0.45 and params:
        p = r.choice(params)
        return ('-' if r.random() < 0.15 else '') + p
    return number(r)


def expr(r, params, depth):
    """A bracketed expression: [t op t op t …] or a function of one."""
    if depth <= 0 or r.random() < 0.25:
        return leaf(r, params)
    k = r.random()
    if k < 0.3:
        fn = r.choice(FUNCS + ['ATAN'])
        if fn == 'ATAN':
            return f'ATAN[{inner(r, params, depth - 1)}]/[{inner(r, params, depth - 1)}]'
        arg = inner(r, params, depth - 1)
        if fn == 'TAN':  # away from ±90°, where the last bit of the angle decides a value of 1e16
            arg = f'[{arg}] MOD 80'
        elif r.random() < 0.85:  # mostly within the function's domain (outside it rs274 stops)
            if fn == 'EXP':
                arg = f'[{arg}] MOD 3'
            elif fn in ('ACOS', 'ASIN'):
                arg = f'[{arg}] MOD 2 - 1'
            elif fn in ('SQRT', 'LN'):
                arg = f'ABS[{arg}] + 0.25'
        return f'{fn}[{arg}]'
    return f'[{inner(r, params, depth - 1)}]' if r.random() < 0.2 else f'-[{inner(r, params, depth - 1)}]' \
        if r.random() < 0.1 else f'[{inner(r, params, depth - 1)}]'


def inner(r, params, depth):
    terms = [expr(r, params, depth) for _ in range(r.randint(1, 4))]
    out = terms[0]
    for t in terms[1:]:
        op = r.choice(OPS)
        if op == '**':  # small exponents (a negative base with a fraction: rs274 stops)
            t = r.choice(['2', '3', '0.5', '-1', '0', t])
        elif op in ('/', 'MOD') and r.random() < 0.8:  # mostly not by zero
            t = r.choice(['3', '-2.5', '0.7', f'[ABS[{t}] + 1]'])
        out += f' {op} {t}'
    return out


def program(r):
    names = ['#1', '#2', '#3', '#<a>', '#<_bb>']
    out = ['G21 G17 G90 G94 G40 G49 G80', 'F100', 'G0 X0 Y0 Z10']
    assigned = []
    for name in names[:2]:  # a start value each
        out.append(f'{name} = {number(r)}')
        assigned.append(name)
    for _ in range(r.randint(4, 14)):
        k = r.random()
        if k < 0.02:  # a predefined parameter, read-only: rs274 stops
            out.append(f"{r.choice(['#<_x>', '#<_Feed>', '#<_value>', '#5420', '#5400'])} = {number(r)}")
        elif k < 0.45:
            n = r.randint(1, 3)
            targets = r.sample(names, n)
            out.append(' '.join(f'{t} = {expr(r, assigned, r.randint(1, 3))}' for t in targets))
            assigned.extend(t for t in targets if t not in assigned)
        elif k < 0.6:
            # an assignment and a move on one line: the move takes the value before the line
            t = r.choice(names[:3])
            out.append(f'{t} = {expr(r, assigned, 2)} G1 X[{r.choice(assigned)} MOD 97] Y{R.f(r.uniform(-5, 5))}')
            if t not in assigned:
                assigned.append(t)
        else:
            axis = r.sample(['X', 'Y', 'Z'], r.randint(1, 2))
            words = []
            for a in axis:
                e = expr(r, assigned, r.randint(1, 3))
                e = e if e.startswith('[') else f'[{e}]'
                words.append(f'{a}[{e} MOD 211 - 100]' if r.random() < 0.7 else f'{a}{e}')
            out.append(f'{r.choice(["G0", "G1"])} ' + ' '.join(words))
    out.append('M2')
    # rs274 refuses lines of 253 characters or more ('Command too long'), a limit postproc does not
    # check yet: longer lines are drawn again.
    return '\n'.join(out) + '\n' if max(map(len, out)) < 253 else program(r)


def main():
    return R.run_seeds(program, 'rs274_expression_compare', sys.argv, 200, 1 / 3)


if __name__ == '__main__':
    sys.exit(main())
