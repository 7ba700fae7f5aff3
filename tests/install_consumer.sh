#!/usr/bin/env bash
# `cmake --install` of the build tree into a scratch prefix, then a project outside postproc
# (tests/consumer) built against it twice: with find_package(postproc) and with pkg-config. Both
# must build and read a small program (3 motions, the arc ending at X22.5 Y-3).
# Usage: install_consumer.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
src=$(cd "$2" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
for f in bin/postproc include/postproc/gcode/dialect.hpp lib/libpostproc_core.a lib/cmake/postproc/postprocConfig.cmake \
  lib/cmake/postproc/postprocTargets.cmake lib/pkgconfig/postproc.pc share/doc/postproc/LICENSE; do
  [[ -e "$work/prefix/$f" ]] || { echo "not installed: $f"; exit 1; }
done
expected="3 motions, last ends at X22.500 Y-3.000"
# 1. CMake package.
cmake -S "$src/tests/consumer" -B "$work/cmake-build" -G Ninja -DCMAKE_PREFIX_PATH="$work/prefix" > "$work/cfg.log"
cmake --build "$work/cmake-build" > "$work/build.log"
got=$("$work/cmake-build/consumer")
[[ "$got" == "$expected" ]] || { echo "find_package consumer printed '$got'"; exit 1; }
# 2. pkg-config.
# shellcheck disable=SC2046
c++ -o "$work/pc-consumer" "$src/tests/consumer/main.cpp" \
  $(PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig" pkg-config --cflags --libs postproc)
got=$("$work/pc-consumer")
[[ "$got" == "$expected" ]] || { echo "pkg-config consumer printed '$got'"; exit 1; }
echo "install_consumer: find_package and pkg-config consumers built and ran: $got"
