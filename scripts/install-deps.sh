#!/usr/bin/env bash
# Installs every build, test and bench dependency of postproc from Debian packages.
# Idempotent; uses sudo when not run as root. Nothing is downloaded at build time.
set -euo pipefail
packages=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libceres-dev libcli11-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libtomlplusplus-dev nlohmann-json3-dev libssl-dev
  time
  chromium chromium-driver python3-selenium python3-pil  # tests/html_render.sh: reports in headless Chromium
  linuxcnc-uspace  # tests/rs274_compare.sh: LinuxCNC's own interpreter (rs274) as the reference
)
# Optional extras: clang for the libFuzzer target, valgrind for instruction counts.
if [[ "${POSTPROC_DEPS_EXTRA:-0}" == 1 ]]; then
  packages+=(clang libclang-rt-14-dev valgrind)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi
SUDO=""
[[ $(id -u) -ne 0 ]] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
