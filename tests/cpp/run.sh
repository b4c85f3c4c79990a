#!/usr/bin/env bash
# Cross-language tests of the kincal C ABI; the project's test command runs this script.
#
#  1. builds kincal-ffi in release (through ffi/install.sh), and in debug with the
#     `test-panic` export;
#  2. C++17 consumer (tests/cpp/consumer.cpp; it also reads a model file `kincal demo` wrote
#     and compares its FK with `kincal predict`, -Wall -Wextra -Werror -pedantic) against the
#     release staticlib and cdylib (both under ASan/UBSan when the compiler has them) and the
#     debug test-panic staticlib (checks that a panic comes back as KINCAL_STATUS_PANIC);
#  3. the header as C99 and C11 (-pedantic); a `kincal export --c-header` of ARIA compiled as
#     strict C11 and linked: its kincal_fk equals kincal_robot_aria's bit for bit;
#  4. ffi/install.sh into a temporary prefix, then the ffi/README.md example built through
#     pkg-config (shared and static) and through CMake find_package(kincal) (static, shared);
#  5. the panic-never proof (tests/cpp/panic_never.sh): the no_std build for
#     thumbv7em-none-eabihf (rust-lld) and the host (gcc, also running tests/cpp/panic_never.c)
#     at opt-levels 3 and s, and the firmware target also at z (scripts/test.sh leaves out
#     host at s: KINCAL_PANIC_NEVER_CONFIGS), every export outside
#     tests/cpp/not_panic_proven.txt checked with nm in the linked binary, and a canary that
#     must break the link on each.
#
# Environment: CARGO_TARGET_DIR (default: ./target of the workspace); CC, CXX (default gcc,
# g++); CI=true turns a missing cmake or pkg-config into a failure (as root they are installed
# with apt-get when missing); KINCAL_PANIC_NEVER_CONFIGS replaces the panic-never matrix
# (TARGET:OPT words; default thumbv7em at opt-levels 3, s and z, the host at 3 and s).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
[[ $target = /* ]] || target=$PWD/$target
export CARGO_TARGET_DIR=$target
CC=${CC:-gcc}
CXX=${CXX:-g++}
work=$(mktemp -d "${TMPDIR:-/tmp}/kincal-ffi-test.XXXXXX")
trap 'rm -rf "$work"' EXIT
cd "$root"

step() { printf '\n=== %s  [%s]\n' "$*" "$(date -u +%T)"; }
fail() {
    echo "run.sh: FAILED: $*" >&2
    exit 1
}

# A tool the test needs: install it as root when missing; without it, fail under CI, else skip.
have_tool() {
    local tool=$1 package=$2
    if ! command -v "$tool" >/dev/null && [[ $(id -u) -eq 0 ]] && command -v apt-get >/dev/null; then
        echo "installing $package (apt-get)"
        apt-get install -y "$package" >/dev/null 2>&1 ||
            { apt-get update >/dev/null 2>&1 && apt-get install -y "$package" >/dev/null 2>&1; } || true
    fi
    if command -v "$tool" >/dev/null; then
        return 0
    fi
    [[ ${CI:-} == true ]] && fail "$tool is required (CI=true) and could not be installed"
    echo "SKIP: $tool not available"
    return 1
}

# The compiler flags of the strict builds; sanitizers when the compiler has them.
cxxflags=(-std=c++17 -Wall -Wextra -Werror -pedantic -O1 -g -I"$root/include")
sanitize=()
if echo 'int main(void){return 0;}' | "$CC" -x c -fsanitize=address,undefined - -o "$work/probe" 2>/dev/null; then
    sanitize=(-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
fi

step "debug build of kincal-ffi with the test-panic export"
cargo build -p kincal-ffi --features test-panic
cp "$target/debug/libkincal.a" "$work/libkincal-test-panic.a"

step "ffi/install.sh (release build of kincal-ffi) into a temporary prefix"
prefix=$work/prefix
"$root/ffi/install.sh" "$prefix"
native=$(sed -n 's/^Libs: [^ ]*libkincal\.a //p' "$prefix/lib/pkgconfig/kincal-static.pc")
read -r -a native_libs <<<"$native"
[[ ${#native_libs[@]} -gt 0 ]] || fail "no native-static-libs in kincal-static.pc"

step "a model file and its predictions written by the CLI (for the consumer's model-file test)"
# (release: the build the project's test command has made already for its other steps)
cargo build -q --release -p kincal-cli --bin kincal
"$target/release/kincal" demo --out "$work/demo" >/dev/null 2>&1 || fail "kincal demo"
export KINCAL_TEST_MODEL=$work/demo/model_noisy.json
export KINCAL_TEST_PREDICT=$work/predict.csv
"$target/release/kincal" predict "$KINCAL_TEST_MODEL" "$work/demo/validation.csv" \
    --out "$KINCAL_TEST_PREDICT"

step "C++ consumer against the staticlib ${sanitize[*]:+(sanitizers on)}"
"$CXX" "${cxxflags[@]}" "${sanitize[@]}" "$here/consumer.cpp" "$target/release/libkincal.a" \
    "${native_libs[@]}" -o "$work/consumer_static"
"$work/consumer_static"

step "C++ consumer against the cdylib ${sanitize[*]:+(sanitizers on)}"
# The cdylib carries SONAME libkincal.so.0 (ffi/build.rs); the loader looks for that name.
dynamic=$(readelf -d "$target/release/libkincal.so")
grep -q 'SONAME.*\[libkincal\.so\.0\]' <<<"$dynamic" ||
    fail "libkincal.so has no SONAME libkincal.so.0"
ln -sf libkincal.so "$target/release/libkincal.so.0"
"$CXX" "${cxxflags[@]}" "${sanitize[@]}" "$here/consumer.cpp" -L"$target/release" -lkincal \
    -Wl,-rpath,"$target/release" -o "$work/consumer_shared"
# (ldd output captured first: `ldd | grep -q` can fail under pipefail when grep exits early)
deps=$(ldd "$work/consumer_shared")
grep -qF "$target/release/libkincal.so" <<<"$deps" ||
    fail "consumer_shared does not load $target/release/libkincal.so"
"$work/consumer_shared"

step "C++ consumer against the debug test-panic staticlib (KINCAL_TEST_PANIC)"
"$CXX" "${cxxflags[@]}" -DKINCAL_TEST_PANIC "$here/consumer.cpp" "$work/libkincal-test-panic.a" \
    "${native_libs[@]}" -o "$work/consumer_panic"
"$work/consumer_panic" 2>"$work/panic.stderr" | tee "$work/panic.stdout"
grep -q "returned KINCAL_STATUS_PANIC" "$work/panic.stdout" || fail "the panic test did not run"

step "the header as C99 and C11"
awk '/^```c$/ {inside = 1; next} /^```$/ && inside {exit} inside' "$root/ffi/README.md" \
    >"$work/example.c"
[[ -s $work/example.c ]] || fail "no \`\`\`c block in ffi/README.md"
for std in c99 c11; do
    "$CC" -std=$std -Wall -Wextra -Werror -pedantic -I"$root/include" -c "$work/example.c" \
        -o "$work/example_$std.o"
done

step "kincal export --c-header: the exported ARIA as strict C11, FK through kincal_fk"
"$target/release/kincal" export aria --c-header "$work/exported_aria.h" --c-name exported_aria
"$CC" -std=c11 -Wall -Wextra -Werror -pedantic -I"$root/include" -I"$work" \
    "$here/exported_model.c" "$target/release/libkincal.a" "${native_libs[@]}" \
    -o "$work/exported_model"
"$work/exported_model"

if have_tool pkg-config pkg-config; then
    step "README example through pkg-config (kincal: shared, kincal-static: static)"
    export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
    [[ $(pkg-config --modversion kincal) == $(cargo pkgid -p kincal-ffi | sed 's/.*[#@]//') ]] ||
        fail "pkg-config version differs from the crate version"
    # shellcheck disable=SC2046 # pkg-config output is a list of words by design
    "$CC" -std=c99 -Wall -Wextra -Werror -pedantic "$work/example.c" \
        $(pkg-config --cflags --libs kincal) -Wl,-rpath,"$prefix/lib" -o "$work/example_pc_shared"
    # shellcheck disable=SC2046
    "$CC" -std=c99 -Wall -Wextra -Werror -pedantic "$work/example.c" \
        $(pkg-config --cflags --libs kincal-static) -o "$work/example_pc_static"
    deps=$(ldd "$work/example_pc_shared")
    grep -qF "$prefix/lib/libkincal.so" <<<"$deps" ||
        fail "example_pc_shared does not load the installed libkincal.so"
    deps=$(ldd "$work/example_pc_static")
    ! grep -q libkincal <<<"$deps" || fail "example_pc_static is not static"
    "$work/example_pc_shared"
    "$work/example_pc_static" >/dev/null
fi

if have_tool cmake cmake; then
    step "README example through CMake find_package(kincal)"
    cmake -S "$here/cmake" -B "$work/cmake-build" -DCMAKE_PREFIX_PATH="$prefix" \
        -DKINCAL_EXAMPLE_SOURCE="$work/example.c" -DCMAKE_C_COMPILER="$CC" >/dev/null
    cmake --build "$work/cmake-build" >/dev/null
    "$work/cmake-build/example_static" >/dev/null
    LD_LIBRARY_PATH=$prefix/lib "$work/cmake-build/example_shared" >/dev/null
    echo "example_static and example_shared built and ran"
fi

step "panic-never proof (tests/cpp/panic_never.sh): ${KINCAL_PANIC_NEVER_CONFIGS:-thumbv7em at 3, s, z; host at 3, s}"
# KINCAL_PANIC_NEVER_CONFIGS (e.g. "thumbv7em-none-eabihf:z") narrows the matrix; the test
# command leaves out host:s (scripts/test.sh).
# shellcheck disable=SC2086 # a list of TARGET:OPT words by design
bash "$here/panic_never.sh" ${KINCAL_PANIC_NEVER_CONFIGS:-}

step "all C ABI tests passed"
