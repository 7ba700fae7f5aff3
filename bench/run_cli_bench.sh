#!/usr/bin/env bash
# End-to-end throughput of the postproc CLI on a generated 5-axis program (check, dump, convert,
# compensate), with LinuxCNC's standalone interpreter (rs274) on the same program as the
# reference point.
#
#   bench/run_cli_bench.sh [BUILD_DIR] [BLOCKS]        defaults: build/release 1000000
#
# Environment:
#   POSTPROC_BENCH_RUNS=3          runs per command; the best wall time is reported
#   POSTPROC_BENCH_1GB=1           also time the three commands on a ~1 GB program
#   POSTPROC_BENCH_1GB_BLOCKS=...  block count of that program (default 18700000, ~1.0 GB)
#   POSTPROC_BENCH_RS274=0         skip rs274 (it needs ~18 s per million blocks)
#   TMPDIR                         where the programs go (needs ~2× the program size free)
#
# A failing command is reported as FAILED with its exit code; the script goes on. Its own exit
# status is 1 if any command failed or convert's output differs from its input, else 0.

set -u -o pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-build/release}"
blocks="${2:-1000000}"
runs="${POSTPROC_BENCH_RUNS:-3}"
# A relative build directory is taken from the current directory, else from the project root.
if [[ ! -d "$build" && -d "$root/$build" ]]; then build="$root/$build"; fi

cli="$build/postproc/postproc"
gen="$build/bench/postproc_gen_program"
timer=/usr/bin/time
status=0

if [[ ! -x "$gen" ]]; then
  echo "run_cli_bench: $gen not found; build the postproc_gen_program target first" >&2
  exit 2
fi
if [[ ! -x "$timer" ]]; then
  echo "run_cli_bench: $timer (GNU time) not found; install the 'time' package" >&2
  exit 2
fi

tmp="$(mktemp -d "${TMPDIR:-/tmp}/postproc-bench.XXXXXX")"
trap 'rm -rf "$tmp"' EXIT

# gen_program FILE BLOCKS DIALECT
generate() {
  if ! "$gen" --blocks "$2" --out "$1" --dialect "$3" --seed 1 2>"$tmp/gen.err"; then
    echo "run_cli_bench: generating $1 failed:" >&2
    cat "$tmp/gen.err" >&2
    exit 2
  fi
}

# Results of the last measure call.
m_time="" m_rss_kb="" m_rc=0 convert_mbs=""

# measure CMD...: runs CMD $runs times under GNU time; keeps the best wall time, the largest peak
# RSS and the first non-zero exit code other than 1. Exit code 1 means "accepted with warnings"
# (ExitCode::unresolved) and is not a failure. stdout is discarded; stderr is kept for the report.
measure() {
  m_time="" m_rss_kb=0 m_rc=0
  local i t rss rc
  for ((i = 0; i < runs; i++)); do
    "$timer" -f '%e %M' -o "$tmp/time.txt" "$@" >/dev/null 2>"$tmp/stderr.txt"
    rc=$?
    read -r t rss <"$tmp/time.txt" 2>/dev/null || { t="" rss=0; }
    # GNU time writes "Command exited with non-zero status N" before the figures.
    if [[ "$t" == Command ]]; then read -r t rss < <(tail -n 1 "$tmp/time.txt"); fi
    if ((rc != 0 && rc != 1)); then
      m_rc=$rc
      return
    fi
    ((rc == 1)) && m_rc=1
    if [[ -z "$m_time" ]] || awk -v a="$t" -v b="$m_time" 'BEGIN { exit !(a < b) }'; then m_time="$t"; fi
    ((rss > m_rss_kb)) && m_rss_kb=$rss
  done
}

# row LABEL FILE: one table line from the last measurement of a command over FILE.
row() {
  local label="$1" file="$2" bytes lines
  bytes=$(stat -c %s "$file")
  lines=$(wc -l <"$file")
  if ((m_rc != 0 && m_rc != 1)); then
    printf '%-34s %10s %12s %10s  FAILED (exit %d): %s\n' "$label" - - - "$m_rc" \
      "$(head -c 200 "$tmp/stderr.txt" | tr '\n' ' ')"
    status=1
    return
  fi
  awk -v label="$label" -v t="$m_time" -v bytes="$bytes" -v lines="$lines" -v rss="$m_rss_kb" -v rc="$m_rc" '
    BEGIN {
      if (t <= 0) t = 0.01  # GNU time resolution is 10 ms
      note = rc == 1 ? "  (exit 1: accepted with warnings)" : ""
      printf "%-34s %10.1f %12.0f %10.1f  %.2f s%s\n", label, bytes / 1e6 / t, lines / t, rss / 1024, t, note
    }'
}

header() {
  printf '%-34s %10s %12s %10s  %s\n' command MB/s blocks/s "peak RSS MB" "best wall time"
}

# bench_cli FILE TAG: check, dump and convert over FILE; convert's output must equal FILE.
bench_cli() {
  local file="$1" tag="$2" out="$tmp/converted.nc"
  if [[ ! -x "$cli" ]]; then
    for c in check "dump csv" convert; do
      printf '%-34s %10s %12s %10s  FAILED: %s not built\n' "$c$tag" - - - "$cli"
    done
    status=1
    return
  fi
  measure "$cli" check --dialect fanuc "$file"
  row "check$tag" "$file"
  # `-o -` into /dev/null rather than `-o /dev/null`: the output is written to a temporary file
  # renamed over the target, which must never be done to a device node.
  measure "$cli" dump --dialect fanuc "$file" --format csv -o -
  row "dump csv$tag" "$file"
  measure "$cli" convert --dialect fanuc "$file" -o "$out"
  row "convert$tag" "$file"
  convert_mbs=""
  if ((m_rc == 0 || m_rc == 1)); then
    convert_mbs=$(awk -v t="$m_time" -v b="$(stat -c %s "$file")" 'BEGIN { if (t <= 0) t = 0.01; print b / 1e6 / t }')
    if cmp -s "$file" "$out"; then
      echo "identity$tag: convert output equals the input ($(stat -c %s "$out") bytes)"
    else
      echo "identity$tag: DIFFERS: $(cmp "$file" "$out" 2>&1 | head -n 1)"
      status=1
    fi
  fi
  rm -f "$out"
  # compensate through the calibrated A/C trunnion of the samples (the program is written for an
  # A/C table-table machine); convert's identity pass is its baseline (same reader and writer).
  measure "$cli" compensate "$file" -m "$root/samples/machines/trunnion_ac_fanuc.toml" -o "$tmp/compensated.nc"
  row "compensate (A/C trunnion)$tag" "$file"
  if ((m_rc == 0)) && [[ -n "$convert_mbs" ]]; then
    awk -v t="$m_time" -v b="$(stat -c %s "$file")" -v c="$convert_mbs" \
      'BEGIN { if (t <= 0) t = 0.01; printf "compensate/convert throughput ratio%s: %.3f\n", "", b / 1e6 / t / c }'
  fi
  rm -f "$tmp/compensated.nc"
}

fanuc="$tmp/bench_fanuc.nc"
linuxcnc="$tmp/bench_linuxcnc.ngc"
generate "$fanuc" "$blocks" fanuc
generate "$linuxcnc" "$blocks" linuxcnc

echo "postproc CLI benchmark: $blocks blocks, $(stat -c %s "$fanuc") bytes, best of $runs runs"
echo "cli: $cli"
echo
header
bench_cli "$fanuc" ""
convert_small_mbs="$convert_mbs"

if [[ "${POSTPROC_BENCH_1GB:-0}" == 1 ]]; then
  big="$tmp/bench_1gb.nc"
  big_blocks="${POSTPROC_BENCH_1GB_BLOCKS:-18700000}"
  generate "$big" "$big_blocks" fanuc
  echo
  echo "~1 GB program: $big_blocks blocks, $(stat -c %s "$big") bytes"
  header
  bench_cli "$big" " (1 GB)"
  rm -f "$big"
fi

echo
if [[ "${POSTPROC_BENCH_RS274:-1}" == 0 ]]; then
  echo "rs274: skipped (POSTPROC_BENCH_RS274=0)"
elif ! command -v rs274 >/dev/null; then
  echo "rs274: not installed (Debian: linuxcnc-uspace); no reference figure"
else
  # -g: batch mode (interpret the whole file, no menu); stdin from /dev/null so that nothing
  # waits for a keyboard; the canonical commands go to stdout, discarded here.
  echo "reference: rs274 -g on the LinuxCNC variant ($blocks blocks, $(stat -c %s "$linuxcnc") bytes)"
  header
  measure rs274 -g "$linuxcnc" </dev/null
  if ((m_rc != 0)); then
    # rs274 -g exits 1 on an interpreter error: that is a failure here, not a warning.
    ((m_rc == 1)) && m_rc=101
    printf '%-34s %10s %12s %10s  FAILED (exit %d): %s\n' "rs274 -g" - - - "$m_rc" \
      "$(grep -v '^executing$' "$tmp/stderr.txt" | head -n 3 | tr '\n' ' ')"
    status=1
  else
    row "rs274 -g (LinuxCNC interpreter)" "$linuxcnc"
    rs_mbs=$(awk -v t="$m_time" -v b="$(stat -c %s "$linuxcnc")" 'BEGIN { if (t <= 0) t = 0.01; print b / 1e6 / t }')
    if [[ -n "$convert_small_mbs" ]]; then
      awk -v c="$convert_small_mbs" -v r="$rs_mbs" \
        'BEGIN { printf "ratio convert/rs274 (throughput): %.1fx\n", c / r }'
    else
      echo "ratio convert/rs274: n/a (convert failed or not built)"
    fi
  fi
fi
exit $status
