#!/usr/bin/env bash
# Golden CLI test: runs one case folder and compares stdout, stderr and the exit code.
#
#   run_golden.sh POSTPROC_BINARY CASE_DIR
#
# CASE_DIR holds:
#   cmd              one line: the arguments after `postproc`; {dir} stands for the case folder. The
#                    command runs inside the case folder and {dir} becomes ".", so every path in the
#                    messages is relative and the expected files do not depend on the checkout.
#   expected_stdout  expected_stderr  expected_rc
#   known_bug        (optional) one line naming a library bug: the expected files then hold the
#                    *correct* output; while the binary still differs the case is skipped (exit 77),
#                    once it matches the case passes and the note says to delete known_bug.
#   input files      for bad_* cases the first line of an input may name the diagnostic it must
#                    raise, e.g. "(expect PP-E102)" or "; expect PP-E201": that code must appear in
#                    stderr.
# The case folder must be unchanged afterwards (no output, temporary or backup file left behind).
# UPDATE_GOLDEN=1 rewrites the expected files from the current binary (then read them and check!).
set -uo pipefail

if [[ $# -ne 2 ]]; then
  echo "usage: $0 POSTPROC_BINARY CASE_DIR" >&2
  exit 64
fi
bin=$(realpath "$1")
case_dir=$(realpath "$2")
name=$(basename "$case_dir")
[[ -x "$bin" ]] || { echo "$name: $bin is not executable" >&2; exit 1; }
[[ -f "$case_dir/cmd" ]] || { echo "$name: no cmd file" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Everything in the case folder, with checksums, to prove the command left it as it was.
snapshot() { (cd "$case_dir" && find . -type f -print0 | sort -z | xargs -0 sha256sum); }
snapshot > "$work/before"

cmd=$(head -n 1 "$case_dir/cmd")
cmd=${cmd//\{dir\}/.}
# The cmd file is part of the repository (trusted); eval gives it shell quoting.
eval "set -- $cmd"
(cd "$case_dir" && "$bin" "$@" < /dev/null > "$work/stdout" 2> "$work/stderr")
rc=$?
echo "$rc" > "$work/rc"

if [[ "${UPDATE_GOLDEN:-0}" == 1 ]]; then
  if [[ -f "$case_dir/known_bug" ]]; then
    echo "$name: has known_bug; expected files hold the correct output and are not rewritten" >&2
  else
    cp "$work/stdout" "$case_dir/expected_stdout"
    cp "$work/stderr" "$case_dir/expected_stderr"
    cp "$work/rc" "$case_dir/expected_rc"
    echo "$name: expected files rewritten (exit $rc); review them before committing"
  fi
  exit 0
fi

failed=0
for what in stdout stderr rc; do
  if [[ ! -f "$case_dir/expected_$what" ]]; then
    echo "$name: missing expected_$what (run with UPDATE_GOLDEN=1 and review)"
    failed=1
  elif ! cmp -s "$case_dir/expected_$what" "$work/$what"; then
    echo "$name: $what differs (--- expected, +++ actual):"
    diff -u --label "expected_$what" --label "actual_$what" "$case_dir/expected_$what" "$work/$what" | head -n 200
    failed=1
  fi
done

# Inputs that name the diagnostic they must raise.
for f in "$case_dir"/*; do
  base=$(basename "$f")
  [[ -f "$f" ]] || continue
  case "$base" in cmd | expected_* | known_bug) continue ;; esac
  code=$(head -n 1 "$f" | grep -oE 'expect (PP-[A-Z][0-9]{3})' | head -n 1 | cut -d' ' -f2)
  if [[ -n "$code" ]] && ! grep -q -- "$code" "$work/stderr"; then
    echo "$name: $base says 'expect $code' but stderr has no $code"
    failed=1
  fi
done

snapshot > "$work/after"
if ! cmp -s "$work/before" "$work/after"; then
  echo "$name: the command changed the case folder:"
  diff -u --label before --label after "$work/before" "$work/after"
  failed=1
fi

if [[ -f "$case_dir/known_bug" ]]; then
  if [[ $failed -ne 0 ]]; then
    echo "$name: SKIPPED, known bug: $(head -n 1 "$case_dir/known_bug")"
    exit 77
  fi
  echo "$name: passes now — the known bug seems fixed; delete $case_dir/known_bug"
  exit 0
fi
if [[ $failed -ne 0 ]]; then
  echo "$name: FAILED (command: postproc $cmd, in $case_dir)"
  exit 1
fi
echo "$name: ok (exit $rc)"
exit 0
