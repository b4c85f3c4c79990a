#!/usr/bin/env bash
# The panic-never proof of the C ABI, on the binaries where it matters: the no_std build of
# kincal-ffi (`--no-default-features --features panic-never`, profile `panic-never`, fat LTO)
# whose panic handler calls kincal_panic_path_remains(), a symbol defined nowhere. For every
# target and opt-level below, the exports of include/kincal.h (minus the ones listed in
# tests/cpp/not_panic_proven.txt) are made GC roots of a --gc-sections link:
#
#  - the link must succeed (a reachable panic leaves kincal_panic_path_remains undefined);
#  - `nm` of the LINKED binary must define every proven export and hold no panic symbol
#    (core::panicking::*, rust_begin_unwind, kincal_panic_path_remains);
#  - the staticlib must export exactly the header's functions (nothing unlisted, nothing lost);
#  - the canary: the same link with kincal_test_panic (panics on purpose) must FAIL on the
#    undefined kincal_panic_path_remains, so the check can fail on that target and level.
#
# thumbv7em-none-eabihf (the firmware target) is linked with rust-lld (no C toolchain needed);
# the host target with $CC, which also links and runs tests/cpp/panic_never.c (FK, IK,
# prepared handle, validation on the no_std build).
#
# Usage: tests/cpp/panic_never.sh [TARGET:OPT ...]   (TARGET `host`: the host's triple)
#   default: thumbv7em-none-eabihf:3 thumbv7em-none-eabihf:s thumbv7em-none-eabihf:z HOST:3 HOST:s
# Opt-level z holds on the firmware target because the firmware path uses no nalgebra operator
# whose assertions need inlining to vanish (at z the optimiser stops inlining `column(k)`,
# views, `Index`, `zeros()`, `identity()`, the products, `dot`, `norm`, `Cholesky`): it goes
# through kincal::fixed3 (nalgebra's arithmetic bit for bit on the storage arrays), reads
# caller arrays with `as_chunks` instead of `chunks_exact` (whose length division by a run-time
# chunk size stays), and indexes with `get`. Opt-level 1 and host z are not in the matrix.
# Environment: CARGO_TARGET_DIR (default ./target of the workspace), CC (default gcc),
# KINCAL_PANIC_NEVER_JOBS (configurations built at once; default: the number of CPUs).
# Each configuration rebuilds kincal-ffi and its dependencies in a target folder of its own
# (3-6 min each on a 2-core machine, nearly all of it one single-threaded fat-LTO codegen
# unit), so the configurations are built side by side and checked one after the other.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
[[ $target = /* ]] || target=$PWD/$target
export CARGO_TARGET_DIR=$target
CC=${CC:-gcc}
work=$(mktemp -d "${TMPDIR:-/tmp}/kincal-panic-never.XXXXXX")
trap 'rm -rf "$work"' EXIT
cd "$root"

fail() {
    echo "panic_never.sh: FAILED: $*" >&2
    exit 1
}

host=$(rustc -vV | sed -n 's/^host: //p')
configs=("$@")
if [[ ${#configs[@]} -eq 0 ]]; then
    configs=(thumbv7em-none-eabihf:3 thumbv7em-none-eabihf:s thumbv7em-none-eabihf:z "$host:3" "$host:s")
fi
lld=$(rustc --print sysroot)/lib/rustlib/$host/bin/rust-lld
[[ -x $lld ]] || fail "rust-lld not found at $lld"

# The exports: every function the header declares. The canary is declared under
# KINCAL_TEST_PANIC; it is never proven and is the symbol that must break the link.
# The std-only exports (declared under KINCAL_STD: the file readers) are not in the no_std
# library and are left out.
declared() { sed -nE 's/^[a-z_ ]*[ *](kincal_[a-z0-9_]+)\(.*/\1/p' | sort -u; }
std_only=$(awk '/^#if defined\(KINCAL_STD\)/ {s = 1; next} s && /^#endif/ {s = 0} s' \
    "$root/include/kincal.h" | declared)
exports=$(comm -23 <(declared <"$root/include/kincal.h") <(echo "$std_only"))
[[ -n $exports ]] || fail "no exports found in include/kincal.h"
grep -qx kincal_test_panic <<<"$exports" || fail "the canary kincal_test_panic is not in the header"
unproven=$(sed -e 's/#.*//' -e 's/[[:space:]]//g' "$here/not_panic_proven.txt" | grep -v '^$' | sort -u)
for f in $unproven; do
    grep -qx "$f" <<<"$exports" || fail "not_panic_proven.txt lists $f, which the header does not declare"
done
proven=$(comm -23 <(echo "$exports") <(printf '%s\n' $unproven kincal_test_panic | sort -u))
n_proven=$(wc -w <<<"$proven")
echo "exports: $(wc -w <<<"$exports") in include/kincal.h; proven: $n_proven; not proven:" $unproven

# Links the no_std staticlib $1 for target $2 with the exports $3 as GC roots into $4.
link() {
    local lib=$1 triple=$2 roots=$3 out=$4 f args=()
    if [[ $triple == thumbv* ]]; then
        for f in $roots; do args+=(-u "$f"); done
        # No program runs: the entry point only silences lld's warning.
        "$lld" -flavor gnu --gc-sections -e kincal_version "${args[@]}" "$lib" -o "$out"
    else
        for f in $roots; do args+=(-Wl,-u,"$f"); done
        "$CC" -std=c11 -O2 -Wall -Wextra -Werror -pedantic -DKINCAL_NO_STD -I"$root/include" \
            "$here/panic_never.c" "$lib" -Wl,--gc-sections "${args[@]}" -lm -o "$out"
    fi
}

# Every root defined in the linked binary, and no panic machinery in it.
check_nm() {
    local bin=$1 roots=$2 syms missing=() f
    syms=$(nm "$bin")
    for f in $roots; do
        grep -qE " [Tt] $f\$" <<<"$syms" || missing+=("$f")
    done
    [[ ${#missing[@]} -eq 0 ]] || fail "$bin does not define: ${missing[*]}"
    if grep -E 'panicking|panic_bounds_check|panic_fmt|rust_begin_unwind|kincal_panic_path_remains' \
        <<<"$syms" >"$work/panic_syms"; then
        cat "$work/panic_syms" >&2
        fail "$bin contains panic symbols (above)"
    fi
}

# One configuration's staticlib, built in its own target folder (so builds can run side by
# side) and copied to $work/libkincal-TRIPLE-OPT.a; the build log goes to $work/build-….log.
build_config() {
    local triple=$1 opt=$2 dir=$target/panic-never/$1-$2
    CARGO_TARGET_DIR=$dir CARGO_PROFILE_PANIC_NEVER_OPT_LEVEL=$opt cargo rustc -p kincal-ffi \
        --profile panic-never --no-default-features --features panic-never \
        --crate-type staticlib --target "$triple" >"$work/build-$triple-$opt.log" 2>&1 &&
        cp "$dir/$triple/panic-never/libkincal.a" "$work/libkincal-$triple-$opt.a"
}

# "host:OPT" names the host's triple.
configs=("${configs[@]/#host:/$host:}")
for config in "${configs[@]}"; do
    triple=${config%%:*}
    if ! rustup target list --installed 2>/dev/null | grep -qx "$triple"; then
        rustup target add "$triple" >/dev/null 2>&1 || fail "rustup target add $triple"
    fi
done
jobs_max=${KINCAL_PANIC_NEVER_JOBS:-$(nproc 2>/dev/null || echo 2)}
[[ $jobs_max =~ ^[1-9][0-9]*$ ]] || fail "KINCAL_PANIC_NEVER_JOBS must be a positive whole number, got '$jobs_max'"
printf '\n=== panic-never builds: %s, %s at once  [%s]\n' "${configs[*]}" "$jobs_max" "$(date -u +%T)"
for config in "${configs[@]}"; do
    while [[ $(jobs -rp | wc -l) -ge $jobs_max ]]; do wait -n || true; done
    build_config "${config%%:*}" "${config#*:}" &
done
wait
# build_config copies the staticlib only when its build succeeded.
for config in "${configs[@]}"; do
    triple=${config%%:*}
    opt=${config#*:}
    if [[ ! -f $work/libkincal-$triple-$opt.a ]]; then
        cat "$work/build-$triple-$opt.log" >&2
        fail "the panic-never build for $triple at opt-level $opt failed (log above)"
    fi
done
echo "built  [$(date -u +%T)]"

summary=()
for config in "${configs[@]}"; do
    triple=${config%%:*}
    opt=${config#*:}
    printf '\n=== panic-never: %s, opt-level %s\n' "$triple" "$opt"
    lib=$work/libkincal-$triple-$opt.a

    # The staticlib exports exactly the header's functions.
    defined=$(nm -g --defined-only "$lib" 2>/dev/null | sed -nE 's/^[0-9a-f]+ T (kincal_[a-z0-9_]+)$/\1/p' | sort -u)
    [[ $defined == "$exports" ]] || {
        diff <(echo "$exports") <(echo "$defined") >&2 || true
        fail "$triple/$opt: the staticlib's exports differ from include/kincal.h (< header, > library)"
    }

    bin=$work/pn-$triple-$opt
    if ! link "$lib" "$triple" "$proven" "$bin" 2>"$work/link.log"; then
        cat "$work/link.log" >&2
        echo "exports that reach a panic ($triple, opt-level $opt):" >&2
        for f in $proven; do
            link "$lib" "$triple" "$f" "$work/one" 2>/dev/null || echo "  $f" >&2
        done
        fail "a panic path remains in the no_std build for $triple at opt-level $opt"
    fi
    check_nm "$bin" "$proven"
    [[ $triple == "$host" ]] && "$bin"
    text=$(size -A "$bin" 2>/dev/null | awk '$1 == ".text" {print $2}')
    echo "linked: $n_proven exports defined, no panic symbol (.text ${text:-?} bytes)"

    # The canary: a reachable panic must break the same link on this target and level.
    if link "$lib" "$triple" "$proven kincal_test_panic" "$work/canary" 2>"$work/canary.log"; then
        fail "$triple/$opt: the canary linked: the check cannot detect panics"
    fi
    grep -q "undefined.*kincal_panic_path_remains" "$work/canary.log" ||
        { cat "$work/canary.log" >&2; fail "$triple/$opt: the canary link failed for another reason"; }
    echo "canary: the link with kincal_test_panic fails on kincal_panic_path_remains, as it must"
    summary+=("$triple opt-level $opt: $n_proven exports proven, canary caught")
done

printf '\n=== panic-never proof holds\n'
printf '  %s\n' "${summary[@]}"
