#!/usr/bin/env python3
"""LinuxCNC's line length limit (issue 16): rs274 stops with "Command too long" at a line of 253
characters or more (its CR counted), on every line it reads up to the program's end -- run or
skipped over -- and never looks at lines after M2. postproc must refuse exactly those programs, at
that line (PP-E207), and read the others. Each case is run through LinuxCNC's own `rs274 -g`.
Usage: rs274_line_length.py POSTPROC"""
import os
import subprocess
import sys
import tempfile


def padded(prefix, length):
    """`prefix` and a comment, `length` characters in all."""
    body = prefix + " ("
    return body + "a" * (length - len(body) - 1) + ")"


def cases():
    for eol in ("\n", "\r\n"):
        cr = eol == "\r\n"
        for n in (250, 251, 252, 253, 254, 300):
            refused = n + cr >= 253
            # A plain program (no resolution).
            yield (f"plain {n} {'crlf' if cr else 'lf'}", ["G21 G90", padded("G1 X1 F100", n), "G1 X2", "M2"], eol,
                   2 if refused else None)
            # With O-words (the resolver): the long line in a branch not taken.
            yield (f"skipped branch {n} {'crlf' if cr else 'lf'}",
                   ["G21 G90", "#1 = 0", "o1 if [#1 GT 0]", padded("G1 X5 F100", n), "o1 endif", "G1 X2 F100", "M2"],
                   eol, 4 if refused else None)
            # In a subroutine's definition that is called.
            yield (f"sub {n} {'crlf' if cr else 'lf'}",
                   ["G21 G90", "o100 sub", padded("G1 X5 F100", n), "o100 endsub", "o100 call", "M2"], eol,
                   3 if refused else None)
    # After M2 nothing is read.
    yield ("after M2 plain", ["G21 G90", "G1 X1 F100", "M2", padded("G1 X9", 300)], "\n", None)
    yield ("after M2 resolved", ["G21 G90", "#1 = 1", "o1 if [#1 GT 0]", "G1 X1 F100", "o1 endif", "M2",
                                 padded("G1 X9", 300)], "\n", None)


def main():
    postproc = sys.argv[1]
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        os.makedirs(os.path.join(tmp, "home"))
        env = dict(os.environ, HOME=os.path.join(tmp, "home"))
        path = os.path.join(tmp, "prog.ngc")
        for name, lines, eol, refused_at in cases():
            with open(path, "w", newline="") as f:
                f.write(eol.join(lines) + eol)
            ref = subprocess.run(["timeout", "20", "rs274", "-g", path], capture_output=True, text=True, env=env)
            rs_refuses = "Command too long" in ref.stdout + ref.stderr
            if rs_refuses != (refused_at is not None):
                print(f"FAIL: {name}: the case expects rs274 to {'refuse' if refused_at else 'read'} it; rs274 says "
                      f"{(ref.stdout + ref.stderr)[-200:]!r}")
                bad += 1
                continue
            got = subprocess.run([postproc, "dump", path, "--dialect", "linuxcnc", "--format", "csv"],
                                 capture_output=True, text=True)
            pp_refuses = "PP-E207" in got.stderr and "LinuxCNC reads at most 252" in got.stderr
            if pp_refuses != rs_refuses:
                print(f"FAIL: {name}: rs274 {'refuses' if rs_refuses else 'reads'} it, postproc "
                      f"{'refuses' if pp_refuses else 'reads'} it: {got.stderr[:300]}")
                bad += 1
            elif refused_at is not None and f"prog.ngc:{refused_at}:" not in got.stderr:
                print(f"FAIL: {name}: refused, but not at line {refused_at}: {got.stderr[:300]}")
                bad += 1
            elif refused_at is None and got.returncode not in (0, 1):
                print(f"FAIL: {name}: postproc exit {got.returncode}: {got.stderr[:300]}")
                bad += 1
    print(f"line length: {bad} case(s) differ from rs274")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
