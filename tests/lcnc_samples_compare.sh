#!/usr/bin/env bash
# LinuxCNC's own sample programs (/usr/share/linuxcnc/ncfiles, Debian package linuxcnc-uspace)
# through rs274 and `postproc dump`: no program may be read differently without a located
# diagnostic (tests/lcnc_samples_compare.py says how they are compared).
# Both read the same tool table (tests/lcnc_samples_tools.tbl: rs274 in inches, postproc in mm), so
# that the programs under cutter radius compensation are compared for real.
# Usage: lcnc_samples_compare.sh POSTPROC [FOLDER]
set -u
dir=${2:-/usr/share/linuxcnc/ncfiles}
command -v rs274 > /dev/null || { echo "FAIL: rs274 missing (scripts/install-deps.sh --test installs linuxcnc-uspace)"; exit 1; }
[[ -d $dir ]] || { echo "FAIL: $dir missing (linuxcnc-uspace)"; exit 1; }
shopt -s nullglob
files=("$dir"/*.ngc)
[[ ${#files[@]} -gt 20 ]] || { echo "FAIL: only ${#files[@]} programs in $dir"; exit 1; }
here=$(dirname "$0")
exec python3 "$here/lcnc_samples_compare.py" "$1" --tool-table "$here/lcnc_samples_tools.tbl" "${files[@]}"
