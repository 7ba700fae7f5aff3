#!/usr/bin/env bash
# The HTML reports of `postproc diff --html` (with a machine, with --predict, without a machine)
# and `postproc predict --html` rendered in headless Chromium through WebDriver (issue 7):
# tests/html_render.py checks console errors, resource loads, element ids, drawn plots, the 3-D
# canvas (drawn, redrawn when dragged), a non-blank full-page screenshot, and that the figures
# shown equal the same run's JSON and stderr. A deliberately broken copy of a report must fail the
# checker (the test can fail). `diff --predict` without servo data is refused with a located
# diagnostic. Needs Debian's chromium, chromium-driver, python3-selenium and python3-pil
# (scripts/install-deps.sh --test, which the README's test command runs); fails when they are missing.
# Usage: html_render.sh POSTPROC SOURCE_DIR
set -u
P=$1
SRC=$2
M=$SRC/samples/machines/trunnion_ac_fanuc.toml
PROG=$SRC/samples/programs/cone_frustum_nas979.nc
PY=/usr/bin/python3
CHECK=$SRC/tests/html_render.py
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

for f in /usr/bin/chromium /usr/bin/chromedriver "$PY"; do
  [[ -x $f ]] || { echo "FAIL: $f missing (scripts/install-deps.sh --test installs it)"; exit 1; }
done
"$PY" -c 'import selenium, PIL' 2> /dev/null || { echo "FAIL: python3-selenium / python3-pil missing (scripts/install-deps.sh --test)"; exit 1; }

"$P" compensate "$PROG" -m "$M" --mode contour -o "$T/cone_c.nc" 2> "$T/compensate.err" ||
  { fail "compensate --mode contour: $(cat "$T/compensate.err")"; exit 1; }
"$P" diff "$PROG" "$T/cone_c.nc" -m "$M" --html "$T/diff.html" --json "$T/diff.json" 2> "$T/diff.err" ||
  fail "diff -m --html: $(cat "$T/diff.err")"
"$P" diff "$PROG" "$T/cone_c.nc" -m "$M" --predict --html "$T/diff_predict.html" --json "$T/diff_predict.json" \
  2> "$T/diff_predict.err" || fail "diff --predict --html: $(cat "$T/diff_predict.err")"
"$P" diff "$PROG" "$T/cone_c.nc" --dialect fanuc --html "$T/diff_plain.html" --json "$T/diff_plain.json" \
  2> "$T/diff_plain.err" || fail "diff --dialect --html: $(cat "$T/diff_plain.err")"
"$P" predict "$PROG" -m "$M" --html "$T/predict.html" 2> "$T/predict.err" || fail "predict --html: $(cat "$T/predict.err")"
cat "$T/diff_predict.err"
# Geometric compensate --html (the README's first command): the original's error on the calibrated
# machine beside the residual of the written program.
"$P" compensate "$SRC/samples/programs/impeller_axes_bc.nc" -m "$SRC/samples/machines/trunnion_bc_fanuc.toml" \
  -o "$T/impeller_c.nc" --html "$T/compensate.html" --json "$T/compensate.json" 2> "$T/compensate_g.err" ||
  fail "compensate --html (geometric): $(cat "$T/compensate_g.err")"
"$P" compensate "$PROG" -m "$M" --mode all -o "$T/cone_all.nc" --html "$T/compensate_all.html" 2> "$T/compensate_all.err" ||
  fail "compensate --mode all --html: $(cat "$T/compensate_all.err")"

# The correction must cut the predicted contour error (the report shows a real before / after).
awk '/predicted contour error, original/ {b = $8} /predicted contour error, corrected/ {a = $8}
     END {exit !(b > 0 && a < 0.5 * b)}' "$T/diff_predict.err" ||
  fail "diff --predict: the corrected program's predicted tool-tip error is not below half the original's"

# --predict without servo data: refused with the located diagnostic, no report written.
grep -v '^kv' "$M" > "$T/nokv.toml"
"$P" diff "$PROG" "$T/cone_c.nc" -m "$T/nokv.toml" --predict --html "$T/refused.html" 2> "$T/refused.err"
rc=$?
[[ $rc -eq 2 ]] || fail "diff --predict without kv: exit code $rc, expected 2"
grep -q 'PP-E611' "$T/refused.err" || fail "diff --predict without kv: no PP-E611 diagnostic: $(cat "$T/refused.err")"
[[ -e $T/refused.html ]] && fail "diff --predict refused but wrote a report"
"$P" diff "$PROG" "$T/cone_c.nc" --dialect fanuc --predict 2> /dev/null
[[ $? -eq 64 ]] || fail "diff --predict without -m is not a usage error"

"$PY" "$CHECK" "$T" diff="$T/diff.html" diff-predict="$T/diff_predict.html" diff-plain="$T/diff_plain.html" \
  predict="$T/predict.html" compensate="$T/compensate.html" \
  compensate-all="$T/compensate_all.html" || fail "the reports do not render cleanly in Chromium (see above)"

# The checker must fail on a broken page: a console error, a missing element, a network resource.
sed -e 's|<body>|<body><script>console.error("injected failure")</script><img src="https://example.invalid/x.png">|' \
  -e 's|id="histogram"|id="histogram-renamed"|' "$T/diff.html" > "$T/broken.html"
cp "$T/diff.json" "$T/broken.json"
cp "$T/diff.err" "$T/broken.err"
if "$PY" "$CHECK" "$T" diff="$T/broken.html" > "$T/broken.out" 2>&1; then
  fail "the checker passed a broken page"
else
  for what in 'console: .*injected failure' '#histogram missing' 'example.invalid'; do
    grep -q "$what" "$T/broken.out" || fail "the checker did not report '$what' on the broken page"
  done
fi

[[ $failures -eq 0 ]] || { echo "$failures failure(s)"; exit 1; }
echo "html_render: all reports render"
