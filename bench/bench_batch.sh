#!/usr/bin/env bash
# Parallel speed-up of `postproc batch` (issue 7): a job folder of PROGRAMS generated 5-axis
# programs of BLOCKS blocks each (10 sub-folders, every program a different seed), compensated
# through the A/C trunnion sample with -j 1 and with -j JOBS (--force, so nothing is skipped);
# prints both wall times and their ratio, and checks that the two output trees are identical.
#
#   bench/bench_batch.sh [BUILD_DIR] [PROGRAMS] [BLOCKS] [JOBS]   defaults: build/release 200 50000 2
#
# Environment: POSTPROC_BENCH_RUNS=1 (runs per setting, the best is kept), TMPDIR (needs about
# 2 × PROGRAMS × BLOCKS × 54 bytes: 1.1 GB for the defaults).
set -u -o pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-build/release}"
programs="${2:-200}"
blocks="${3:-50000}"
jobs="${4:-2}"
runs="${POSTPROC_BENCH_RUNS:-1}"
if [[ ! -d "$build" && -d "$root/$build" ]]; then build="$root/$build"; fi
cli="$build/postproc/postproc"
gen="$build/bench/postproc_gen_program"
for x in "$cli" "$gen"; do
  [[ -x "$x" ]] || { echo "bench_batch: $x not found; build the postproc_cli and postproc_gen_program targets" >&2; exit 2; }
done
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
machine="$root/samples/machines/trunnion_ac_fanuc.toml"

echo "bench_batch: generating $programs programs of $blocks blocks in $tmp/jobs"
for ((i = 0; i < programs; ++i)); do
  d="$tmp/jobs/job$((i % 10))"
  mkdir -p "$d"
  "$gen" --blocks "$blocks" --seed $((i + 1)) --out "$d/part$i.nc" > /dev/null 2>&1 || { echo "bench_batch: generator failed" >&2; exit 2; }
done
bytes=$(du -sb "$tmp/jobs" | cut -f1)

best() { # JOBS OUT → best wall seconds over $runs runs
  local b=""
  for ((r = 0; r < runs; ++r)); do
    local t0 t1
    t0=$(date +%s.%N)
    "$cli" batch "$tmp/jobs" -m "$machine" -o "$tmp/$2" -j "$1" --force -q 2> "$tmp/err.$1" ||
      { echo "bench_batch: batch -j $1 failed:" >&2; tail -5 "$tmp/err.$1" >&2; exit 1; }
    t1=$(date +%s.%N)
    b=$(awk -v a="$t0" -v z="$t1" -v b="$b" 'BEGIN { t = z - a; if (b == "" || t < b) b = t; printf "%.3f", b }')
  done
  echo "$b"
}
t1=$(best 1 out1)
tn=$(best "$jobs" outn)
same="identical"
diff -rq -x 'postproc-manifest*' "$tmp/out1" "$tmp/outn" > /dev/null || same="DIFFERENT"
awk -v p="$programs" -v bl="$blocks" -v by="$bytes" -v t1="$t1" -v tn="$tn" -v j="$jobs" -v s="$same" 'BEGIN {
  printf "batch: %d programs × %d blocks (%.0f MB), %d cores reported by nproc\n", p, bl, by / 1e6, '"$(nproc)"'
  printf "  -j 1: %.2f s (%.0f k blocks/s)\n", t1, p * bl / t1 / 1e3
  printf "  -j %d: %.2f s (%.0f k blocks/s)\n", j, tn, p * bl / tn / 1e3
  printf "speed-up -j %d / -j 1: %.2f (target >= 1.8 for -j 2)\n", j, t1 / tn
  printf "outputs of -j 1 and -j %d: %s\n", j, s
}'
[[ $same == identical ]]
