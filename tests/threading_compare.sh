#!/usr/bin/env bash
# Threading cycles (docs/threading.md): LinuxCNC G76 programs in tests/threading/linuxcnc agree
# move for move with LinuxCNC's own interpreter (`rs274 -g`, Debian package linuxcnc-uspace);
# tests/threading_compare.py says how they are compared.
# Usage: threading_compare.sh POSTPROC SOURCE_DIR
set -u
command -v rs274 > /dev/null || { echo "FAIL: rs274 missing (scripts/install-deps.sh --test installs linuxcnc-uspace)"; exit 1; }
SRC=$(realpath "$2")
exec python3 "$SRC/tests/threading_compare.py" "$(realpath "$1")" "$SRC"/tests/threading/linuxcnc/*.ngc
