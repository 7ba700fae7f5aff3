#!/usr/bin/env bash
# Installs postproc's dependencies from Debian 12 packages. Idempotent; uses sudo when not run
# as root. Nothing is downloaded at build time.
#
#   scripts/install-deps.sh            what building and running the tool needs (the `tool` preset)
#   scripts/install-deps.sh --test     adds what the tests and benchmarks need (the `release` preset):
#                                      GoogleTest, Google Benchmark, headless Chromium with WebDriver
#                                      (tests/html_render.sh) and LinuxCNC's interpreter rs274
#                                      (tests/rs274_compare.sh and the other comparisons), and
#                                      clang with its sanitizer runtimes (the `asan` presets)
#   scripts/install-deps.sh --extra    adds --test's packages and valgrind (instruction counts;
#                                      clang also serves libFuzzer, the `fuzz` preset);
#                                      POSTPROC_DEPS_EXTRA=1 does the same
set -euo pipefail
mode=tool
for arg in "$@"; do
  case "$arg" in
    --test) [[ $mode == extra ]] || mode=test ;;
    --extra) mode=extra ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "install-deps: unknown argument '$arg' (use --test or --extra)" >&2; exit 64 ;;
  esac
done
[[ "${POSTPROC_DEPS_EXTRA:-0}" == 1 ]] && mode=extra

packages=(
  build-essential cmake ninja-build
  libeigen3-dev libceres-dev libcli11-dev libfmt-dev
  libtomlplusplus-dev nlohmann-json3-dev libssl-dev
)
if [[ $mode != tool ]]; then
  packages+=(
    pkg-config time
    zsh fish groff-base  # tests/docgen_cli.sh: the completions in each shell, the man pages through groff
    libgtest-dev libgmock-dev libbenchmark-dev
    chromium chromium-driver python3-selenium python3-pil  # tests/html_render.sh: reports in headless Chromium
    linuxcnc-uspace  # tests/rs274_compare.sh: LinuxCNC's own interpreter (rs274) as the reference
    pybind11-dev python3-dev python3-numpy python3-pytest  # the Python module and its tests (docs/python.md)
    clang libclang-rt-14-dev  # the asan presets: CI runs the input-facing tests with ASan + UBSan
  )
fi
if [[ $mode == extra ]]; then
  packages+=(valgrind)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#packages[@]} packages present ($mode)"
  exit 0
fi
SUDO=""
[[ $(id -u) -ne 0 ]] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
