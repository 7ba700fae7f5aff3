#!/usr/bin/env bash
# Speed-up of `postproc compensate -j N` on ONE program (issue 18 item 3): a generated 5-axis
# program of BLOCKS blocks through the A/C trunnion sample, compensated with -j 1 and -j JOBS in
# interleaved rounds (the machine is shared and noisy: each round's two runs are back to back and
# the ratio is taken per round). Prints every round, the median paired ratio, peak RSS and checks
# that the outputs and reports (less file names and seconds) are identical.
#
#   bench/bench_compensate_jobs.sh [BUILD_DIR] [BLOCKS] [JOBS] [ROUNDS]   defaults: build/release 300000 2 5
#
# Environment: TMPDIR (needs about 3 × BLOCKS × 60 bytes).
set -u -o pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-build/release}"
blocks="${2:-300000}"
jobs="${3:-2}"
rounds="${4:-5}"
if [[ ! -d "$build" && -d "$root/$build" ]]; then build="$root/$build"; fi
cli="$build/postproc/postproc"
gen="$build/bench/postproc_gen_program"
for x in "$cli" "$gen" /usr/bin/time; do
  [[ -x "$x" ]] || { echo "bench_compensate_jobs: $x not found (build postproc and postproc_gen_program; GNU time)" >&2; exit 2; }
done
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
machine="$root/samples/machines/trunnion_ac_fanuc.toml"
"$gen" --blocks "$blocks" --seed 1 --out "$tmp/in.nc" > /dev/null 2>&1 || { echo "bench_compensate_jobs: generator failed" >&2; exit 2; }

run() { # JOBS TAG → "seconds rss_kb"
  /usr/bin/time -f '%e %M' -o "$tmp/time.$2" "$cli" compensate "$tmp/in.nc" -m "$machine" -o "$tmp/out.$2.nc" \
    --report "$tmp/report.$2.json" -j "$1" 2> "$tmp/err.$2" ||
    { echo "bench_compensate_jobs: compensate -j $1 failed:" >&2; tail -5 "$tmp/err.$2" >&2; exit 1; }
  tail -n 1 "$tmp/time.$2"
}
ratios=()
for ((r = 1; r <= rounds; ++r)); do
  read -r t1 m1 < <(run 1 one)
  read -r tn mn < <(run "$jobs" many)
  ratio=$(awk -v a="$t1" -v b="$tn" 'BEGIN { printf "%.3f", a / b }')
  ratios+=("$ratio")
  printf 'round %d: -j 1 %.2f s (%d MB)   -j %d %.2f s (%d MB)   ratio %s\n' "$r" "$t1" $((m1 / 1024)) "$jobs" "$tn" \
    $((mn / 1024)) "$ratio"
done
median=$(printf '%s\n' "${ratios[@]}" | sort -n | awk '{ a[NR] = $1 } END { print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }')
same="identical"
cmp -s "$tmp/out.one.nc" "$tmp/out.many.nc" || same="DIFFERENT"
python3 - "$tmp/report.one.json" "$tmp/report.many.json" << 'EOF' || same="$same; reports DIFFERENT"
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
for r in (a, b):
    for k in ("seconds", "output", "parallel"):
        r.pop(k, None)
sys.exit(0 if a == b else 1)
EOF
chunks=$(grep -o '"chunks": [0-9]*' "$tmp/report.many.json" | grep -o '[0-9]*$')
recomputed=$(grep -o '"recomputed": [0-9]*' "$tmp/report.many.json" | grep -o '[0-9]*$')
echo "compensate -j $jobs / -j 1 on one $blocks-block program: median ratio $median over $rounds rounds (target >= 1.7 for -j 2);" \
  "$chunks chunks, $recomputed corrected again; outputs: $same"
[[ $same == identical ]]
