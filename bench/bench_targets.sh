#!/usr/bin/env bash
# Issue 18's figures, each as a ratio against a baseline measured in the same script and the same
# round (the machine is shared and noisy: every round runs all commands back to back, the ratio is
# taken per round, the median over the rounds is printed; wall time of each process, peak RSS from
# GNU time):
#
#   geometric A/C / convert          one generated 5-axis program (postproc_gen_program), -j 1
#   geometric A/C -j 1 / -j JOBS     the same program
#   geometric 3-PRS / convert        the 3-PRS sample's moves repeated to BLOCKS lines, -j 1
#   geometric hexapod / convert      the hexapod sample's moves repeated to BLOCKS lines, -j 1
#   contour / geometric, all / geometric   the generated program cut to CONTOUR_BLOCKS lines
#   contour peak RSS per block       contour on CONTOUR_BLOCKS and 2 × CONTOUR_BLOCKS lines
#
#   bench/bench_targets.sh [BUILD_DIR] [BLOCKS] [CONTOUR_BLOCKS] [ROUNDS] [JOBS]
#   defaults: build/release 200000 20000 3 2
#
# rs274 / convert and convert / bare pass: bench/run_cli_bench.sh and postproc_bench_lexer;
# batch -j: bench/bench_batch.sh.
set -u -o pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-build/release}"
blocks="${2:-200000}"
cblocks="${3:-20000}"
rounds="${4:-3}"
jobs="${5:-2}"
if [[ ! -d "$build" && -d "$root/$build" ]]; then build="$root/$build"; fi
cli="$build/postproc/postproc"
gen="$build/bench/postproc_gen_program"
for x in "$cli" "$gen" /usr/bin/time; do
  [[ -x "$x" ]] || { echo "bench_targets: $x not found (build postproc and postproc_gen_program; GNU time)" >&2; exit 2; }
done
command -v python3 > /dev/null || { echo "bench_targets: python3 is needed to repeat the sample programs" >&2; exit 2; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
machines="$root/samples/machines"

"$gen" --blocks "$blocks" --seed 1 --out "$tmp/ac.nc" > /dev/null 2>&1 || { echo "bench_targets: generator failed" >&2; exit 2; }
"$gen" --blocks "$cblocks" --seed 1 --out "$tmp/ac_c.nc" > /dev/null 2>&1 || exit 2
"$gen" --blocks $((2 * cblocks)) --seed 1 --out "$tmp/ac_c2.nc" > /dev/null 2>&1 || exit 2
# A sample's feed moves (after its set-up lines) repeated forwards and backwards to BLOCKS lines.
repeat() { # SAMPLE SETUP_LINES OUT
  python3 - "$root/samples/programs/$1" "$2" "$3" "$blocks" << 'EOF'
import re, sys
src, setup, out, n = open(sys.argv[1]).read().splitlines(), int(sys.argv[2]), sys.argv[3], int(sys.argv[4])
head = src[:setup]
body = [re.sub(r'^N\d+ ', '', l) for l in src[setup:] if re.match(r'^N\d+ X', l)]
lines, k = list(head), 0
while len(lines) < n:
    lines += body if k % 2 == 0 else body[::-1]
    k += 1
lines += ['G0 Z50.', 'M30', '%']
open(out, 'w').write('\n'.join(lines) + '\n')
EOF
}
repeat tilted_pocket_3prs.nc 8 "$tmp/prs.nc" || exit 2
repeat freeform_hexapod_g43_5.nc 7 "$tmp/hex.nc" || exit 2

t=0 rss=0
run() { # NAME ARGS… → sets t (s) and rss (kB)
  local name="$1"
  shift
  local t0 t1
  t0=$(date +%s.%N)
  /usr/bin/time -f '%M' -o "$tmp/time" "$cli" "$@" > /dev/null 2> "$tmp/err.$name"
  local rc=$?
  t1=$(date +%s.%N)
  if ((rc != 0 && rc != 1)); then
    echo "bench_targets: $name failed ($rc):" >&2
    tail -3 "$tmp/err.$name" >&2
    exit 1
  fi
  t=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.4f", b - a }')
  rss=$(tail -n 1 "$tmp/time")
}
declare -A ratios
add() { ratios[$1]+="$(awk -v a="$2" -v b="$3" 'BEGIN { printf "%.3f", (b > 0 ? a / b : 0) }') "; }
rss_contour1=0 rss_contour2=0
for ((r = 1; r <= rounds; ++r)); do
  run convert convert "$tmp/ac.nc" --dialect fanuc -o "$tmp/o.nc"; conv=$t
  run geo1 compensate "$tmp/ac.nc" -m "$machines/trunnion_ac_fanuc.toml" -o "$tmp/o.nc" -j 1; geo1=$t
  run geon compensate "$tmp/ac.nc" -m "$machines/trunnion_ac_fanuc.toml" -o "$tmp/o.nc" -j "$jobs"; geon=$t
  add "geometric A/C / convert (-j 1)" "$geo1" "$conv"
  add "geometric A/C -j 1 / -j $jobs" "$geo1" "$geon"
  run convert_prs convert "$tmp/prs.nc" --dialect fanuc -o "$tmp/o.nc"; cp=$t
  run prs compensate "$tmp/prs.nc" -m "$machines/hybrid_3prs_doc001.toml" -o "$tmp/o.nc" -j 1
  add "geometric 3-PRS / convert (-j 1)" "$t" "$cp"
  run convert_hex convert "$tmp/hex.nc" --dialect fanuc -o "$tmp/o.nc"; ch=$t
  run hex compensate "$tmp/hex.nc" -m "$machines/hexapod_doc003.toml" -o "$tmp/o.nc" -j 1
  add "geometric hexapod / convert (-j 1)" "$t" "$ch"
  run cgeo compensate "$tmp/ac_c.nc" -m "$machines/trunnion_ac_fanuc.toml" -o "$tmp/o.nc" -j 1; cg=$t
  run contour compensate "$tmp/ac_c.nc" -m "$machines/trunnion_ac_fanuc.toml" -o "$tmp/o.nc" --mode contour -j 1
  add "contour / geometric" "$t" "$cg"
  rss_contour1=$rss
  run all compensate "$tmp/ac_c.nc" -m "$machines/trunnion_ac_fanuc.toml" -o "$tmp/o.nc" --mode all -j 1
  add "all / geometric" "$t" "$cg"
  if ((r == 1)); then
    run contour2 compensate "$tmp/ac_c2.nc" -m "$machines/trunnion_ac_fanuc.toml" -o "$tmp/o.nc" --mode contour -j 1
    rss_contour2=$rss
  fi
done
median() { tr ' ' '\n' | grep -v '^$' | sort -n | awk '{ a[NR] = $1 } END { print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }'; }
echo "bench_targets: $blocks blocks (contour: $cblocks), $rounds rounds, nproc $(nproc)"
for k in "geometric A/C / convert (-j 1)" "geometric A/C -j 1 / -j $jobs" "geometric 3-PRS / convert (-j 1)" \
         "geometric hexapod / convert (-j 1)" "contour / geometric" "all / geometric"; do
  printf '  %-36s median %6.2f   rounds: %s\n' "$k" "$(echo "${ratios[$k]}" | median)" "${ratios[$k]}"
done
awk -v a="$rss_contour1" -v b="$rss_contour2" -v n="$cblocks" 'BEGIN {
  printf "  contour peak RSS: %.0f MB at %d blocks, %.0f MB at %d: %.2f KiB per block\n", a / 1024, n, b / 1024, 2 * n, (b - a) / n
}'
