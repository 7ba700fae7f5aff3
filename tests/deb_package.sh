#!/usr/bin/env bash
# CPack's Debian package of a build tree (issue 20): `cpack -G DEB` builds it; it must hold the
# command, a man page per command, the completions, the library with its headers and its CMake
# and pkg-config files; its Depends must name the shared libraries the command links (from
# dpkg-shlibdeps); and the command unpacked from it must run.
# Usage: deb_package.sh BUILD_DIR
set -u
B=$1
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

(cd "$B" && cpack -G DEB -B "$T/out" > "$T/cpack.log" 2>&1) || { cat "$T/cpack.log"; echo "FAIL: cpack"; exit 1; }
deb=$(ls "$T"/out/postproc_*.deb 2> /dev/null | head -1)
[[ -n $deb ]] || { echo "FAIL: no .deb written"; exit 1; }
[[ $(dpkg-deb -f "$deb" Package) == postproc ]] || fail "Package is not postproc"
dpkg-deb -f "$deb" Version | grep -qE '^[0-9]+\.[0-9]+\.[0-9]+$' || fail "Version: $(dpkg-deb -f "$deb" Version)"
depends=$(dpkg-deb -f "$deb" Depends)
for lib in libfmt libtomlplusplus libc6 libstdc++6; do
  grep -q "$lib" <<<"$depends" || fail "Depends lacks $lib: $depends"
done
dpkg-deb -c "$deb" | awk '{print $6}' > "$T/files"
for f in ./usr/bin/postproc ./usr/share/man/man1/postproc-compensate.1 ./usr/share/man/man1/postproc-calibrate.1 \
  ./usr/share/bash-completion/completions/postproc ./usr/share/zsh/site-functions/_postproc \
  ./usr/share/fish/vendor_completions.d/postproc.fish ./usr/lib/cmake/postproc/postprocConfig.cmake \
  ./usr/lib/pkgconfig/postproc.pc ./usr/include/postproc/compensation/compensate.hpp ./usr/share/doc/postproc/LICENSE; do
  grep -qxF "$f" "$T/files" || fail "the package lacks $f"
done
grep -q '^./usr/lib/.*libpostproc_core\.a$' "$T/files" || fail "the package lacks the library"
dpkg-deb -x "$deb" "$T/root" || fail "dpkg-deb -x"
"$T/root/usr/bin/postproc" --version > "$T/version" 2>&1 || fail "the packaged command does not run: $(cat "$T/version")"
grep -q "$(dpkg-deb -f "$deb" Version)" "$T/version" || fail "postproc --version ($(cat "$T/version")) is not the package's"
[[ $failures -eq 0 ]] || { echo "$failures failure(s)"; exit 1; }
echo "deb_package: $(basename "$deb") holds $(wc -l < "$T/files") entries; Depends: $depends"
