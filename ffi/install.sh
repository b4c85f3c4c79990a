#!/usr/bin/env bash
# Builds the kincal C ABI in release and installs it for C/C++ consumers:
#   PREFIX/include/kincal.h
#   PREFIX/lib/libkincal.a, PREFIX/lib/libkincal.so.0 (SONAME) and the link libkincal.so
#   PREFIX/lib/pkgconfig/kincal.pc (shared), kincal-static.pc (static)
#   PREFIX/lib/cmake/kincal/kincalConfig.cmake, kincalConfigVersion.cmake
#
# Usage: ffi/install.sh PREFIX
# The cargo target directory is $CARGO_TARGET_DIR, else ./target of the workspace.
set -euo pipefail

if [[ $# -ne 1 || -z $1 ]]; then
    echo "usage: $0 PREFIX" >&2
    exit 2
fi

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/.." && pwd)
prefix=$1
[[ $prefix = /* ]] || prefix=$PWD/$prefix
target=${CARGO_TARGET_DIR:-$root/target}
[[ $target = /* ]] || target=$PWD/$target
export CARGO_TARGET_DIR=$target

cd "$root"
# One release build of both crate types; rustc also reports the system libraries the static
# library needs (replayed from cargo's cache when the build is fresh).
# cargo's lines ("Compiling ...") go to stderr as they come, so a first build is not silent.
echo "install.sh: building the release library (about 3-4 minutes on a first build)..." >&2
build_log=$(cargo rustc --release -p kincal-ffi -- --print native-static-libs 2>&1 |
    while IFS= read -r line; do
        printf '%s\n' "$line" >&2
        printf '%s\n' "$line"
    done) || exit 1
native=$(printf '%s\n' "$build_log" | sed -n 's/^note: native-static-libs: //p' | tail -n 1)
if [[ -z $native ]]; then
    printf '%s\n' "$build_log" >&2
    echo "install.sh: rustc did not report native-static-libs" >&2
    exit 1
fi
cmake_native=$(printf '%s\n' "$native" | sed -e 's/^-l//' -e 's/ -l/;/g')
version=$(cargo pkgid -p kincal-ffi | sed 's/.*[#@]//')

install -d "$prefix/include" "$prefix/lib/pkgconfig" "$prefix/lib/cmake/kincal"
install -m 644 "$root/include/kincal.h" "$prefix/include/kincal.h"
install -m 644 "$target/release/libkincal.a" "$prefix/lib/libkincal.a"
# The library's SONAME is libkincal.so.0 (ffi/build.rs): the file under that name, and the
# development link libkincal.so for -lkincal.
install -m 755 "$target/release/libkincal.so" "$prefix/lib/libkincal.so.0"
ln -sf libkincal.so.0 "$prefix/lib/libkincal.so"

# Replacement text for sed: escape the characters special in a replacement (\, &, |).
escape() { printf '%s' "$1" | sed -e 's/[\\&|]/\\&/g'; }
fill() {
    sed -e "s|@PREFIX@|$(escape "$prefix")|g" \
        -e "s|@VERSION@|$(escape "$version")|g" \
        -e "s|@NATIVE_STATIC_LIBS@|$(escape "$native")|g" \
        -e "s|@CMAKE_NATIVE_LIBS@|$(escape "$cmake_native")|g" \
        "$here/pkg/$1" >"$2"
}
fill kincal.pc.in "$prefix/lib/pkgconfig/kincal.pc"
fill kincal-static.pc.in "$prefix/lib/pkgconfig/kincal-static.pc"
fill kincalConfig.cmake.in "$prefix/lib/cmake/kincal/kincalConfig.cmake"
fill kincalConfigVersion.cmake.in "$prefix/lib/cmake/kincal/kincalConfigVersion.cmake"

echo "installed kincal $version into $prefix (static link needs: $native)"
