#!/usr/bin/env bash
# Issue 3 bench: a LinuxCNC program whose 1,000,000 blocks come from a `while` over PASSES passes of
# MOVES moves (each move's values are expressions of the loop counter), against the same motions
# written flat (the program `postproc` resolves it into). Prints the `dump` time of both and the
# ratio flat / looped (target: the looped program at ≥ 50 % of the flat program's dump speed),
# and checks that both dumps give the same motions.
#
#   bench/bench_resolve.sh [BUILD_DIR] [PASSES] [MOVES]      defaults: build/release 1000 1000
#
# POSTPROC_BENCH_CALLGRIND=1 counts instructions with valgrind's callgrind instead of timing (the
# same figure on a loaded machine; use fewer passes, e.g. 100, as it runs ~50x slower).
set -u -o pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-build/release}"
passes="${2:-1000}"
moves="${3:-1000}"
runs="${POSTPROC_BENCH_RUNS:-3}"
if [[ ! -d "$build" && -d "$root/$build" ]]; then build="$root/$build"; fi
cli="$build/postproc/postproc"
[[ -x "$cli" ]] || { echo "bench_resolve: $cli not found" >&2; exit 2; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
python3 - "$tmp" "$passes" "$moves" <<'PY'
import sys
d, passes, moves = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
with open(f"{d}/looped.ngc", "w") as f:
    f.write("G21 G90 G17 G94\nF1500\nG0 X0 Y0 Z5\n#1 = 0\no100 while [#1 LT %d]\n" % passes)
    for k in range(moves):
        f.write("  G1 X[%d.%03d + #1 * 0.01] Y[SIN[#1 + %d] * 20] Z[-#1 * 0.001]\n" % (k // 1000, k % 1000, k % 360))
    f.write("  #1 = [#1 + 1]\no100 endwhile\nM2\n")
PY
# The flat program: what the looped one resolves into (postproc dump's motions written back as G1).
"$cli" dump "$tmp/looped.ngc" --dialect linuxcnc --format csv -o "$tmp/looped.csv" 2> "$tmp/err" || { cat "$tmp/err" >&2; exit 1; }
python3 - "$tmp" <<'PY'
import csv, sys
d = sys.argv[1]
with open(f"{d}/flat.ngc", "w") as f:
    f.write("G21 G90 G17 G94\nF1500\n")
    for r in csv.DictReader(open(f"{d}/looped.csv")):
        f.write(("G0" if r["motion"] == "rapid" else "G1") + " X%s Y%s Z%s\n" % (r["x"], r["y"], r["z"]))
    f.write("M2\n")
PY
best() {
  local b=""
  for ((r = 0; r < runs; ++r)); do
    local t0 t1
    t0=$(date +%s.%N)
    "$cli" dump "$1" --dialect linuxcnc --format csv -o "$tmp/out.csv" 2> /dev/null || { echo "dump $1 failed" >&2; exit 1; }
    t1=$(date +%s.%N)
    b=$(awk -v a="$t0" -v z="$t1" -v b="$b" 'BEGIN { t = z - a; if (b == "" || t < b) b = t; printf "%.3f", b }')
  done
  echo "$b"
}
blocks=$((passes * moves))
if [[ "${POSTPROC_BENCH_CALLGRIND:-0}" == 1 ]]; then
  command -v valgrind > /dev/null || { echo "bench_resolve: valgrind not found" >&2; exit 2; }
  instr() {
    valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.out" "$cli" dump "$1" --dialect linuxcnc --format csv \
      -o "$tmp/out.csv" 2>&1 | sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
  }
  inf=$(instr "$tmp/flat.ngc")
  inl=$(instr "$tmp/looped.ngc")
  awk -v f="$inf" -v l="$inl" -v n="$blocks" 'BEGIN {
    printf "dump, %d motions: flat program %.0f M instructions (%.0f per block), looped program %.0f M (%.0f per block)\n", n, f / 1e6, f / n, l / 1e6, l / n
    printf "looped / flat speed by instructions: %.0f %% (target >= 50 %%)\n", 100 * f / l
  }'
  exit 0
fi
tf=$(best "$tmp/flat.ngc")
tl=$(best "$tmp/looped.ngc")
awk -v tf="$tf" -v tl="$tl" -v n="$blocks" 'BEGIN {
  printf "dump, %d motions: flat program %.2f s (%.0f k blocks/s), looped program %.2f s (%.0f k blocks/s)\n", n, tf, n / tf / 1e3, tl, n / tl / 1e3
  printf "looped / flat speed: %.0f %% (target >= 50 %%)\n", 100 * tf / tl
}'
