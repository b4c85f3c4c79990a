#!/usr/bin/env bash
# Runs every fuzz target (or the ones named) for FUZZ_SECONDS each (default 10: the CI smoke
# run), or for FUZZ_RUNS executions each when that is set (the long run), and fails on the
# first crash, leak or timeout. Crash inputs land in fuzz/artifacts/TARGET/; turn each into a
# regression test (README.md).
#
#   fuzz/smoke.sh                          # all targets, 10 s each
#   FUZZ_SECONDS=600 fuzz/smoke.sh csv     # a longer run of targets whose name contains csv
#   FUZZ_RUNS=10000000 fuzz/smoke.sh       # the long run: 10^7 executions per target
#   FUZZ_FAST=1 FUZZ_RUNS=10000000 fuzz/smoke.sh ros_bag
#                                          # the same without AddressSanitizer and without
#                                          # comparison tracing: 5-40x the executions per
#                                          # second; debug assertions and overflow checks stay
#
# Needs cargo-fuzz (installed here with `cargo install cargo-fuzz` when missing) and a C++
# compiler (libFuzzer is built from source). libFuzzer needs nightly-only rustc flags: on a
# stable toolchain they are unlocked with RUSTC_BOOTSTRAP=1 (a stable toolchain ships the
# AddressSanitizer runtime, so the default `-s address` works). With CI=true a missing tool
# that cannot be installed is a failure, never a skip.
set -euo pipefail
cd "$(dirname "$0")"
SECS=${FUZZ_SECONDS:-10}
CARGO_FUZZ_VERSION=0.13.2

fail() { printf 'fuzz/smoke.sh: error: %s\n' "$*" >&2; exit 1; }

RUNS=${FUZZ_RUNS:-}
if [ -n "$RUNS" ]; then
    case $RUNS in *[!0-9]*) fail "FUZZ_RUNS must be a whole number of executions, got '$RUNS'" ;; esac
    budget=(-runs="$RUNS")
    what="$RUNS executions"
else
    case $SECS in '' | *[!0-9]*) fail "FUZZ_SECONDS must be a whole number of seconds, got '$SECS'" ;; esac
    budget=(-max_total_time="$SECS")
    what="${SECS}s"
fi

command -v cargo >/dev/null || fail "cargo is missing (install Rust with rustup)"
command -v c++ >/dev/null || command -v g++ >/dev/null || command -v clang++ >/dev/null ||
    fail "a C++ compiler is missing (apt-get install g++): libFuzzer is built from source"
if ! cargo fuzz --version >/dev/null 2>&1; then
    echo "==> installing cargo-fuzz $CARGO_FUZZ_VERSION"
    cargo install cargo-fuzz --locked --version "$CARGO_FUZZ_VERSION" ||
        fail "cannot install cargo-fuzz (cargo install cargo-fuzz)"
fi
if ! rustc --version | grep -q nightly; then
    export RUSTC_BOOTSTRAP=1
fi

all=$(cargo fuzz list)
targets=()
if [ $# -eq 0 ]; then
    read -r -a targets <<<"$(echo $all)"
else
    for pat in "$@"; do
        for t in $all; do
            case $t in *"$pat"*) targets+=("$t") ;; esac
        done
    done
    [ ${#targets[@]} -gt 0 ] || fail "no target matches: $* (targets: $(echo $all))"
fi

# FUZZ_FAST: no sanitizer (the parsers are safe Rust; c_abi's unsafe boundary wants ASan) and
# no comparison tracing (libFuzzer then learns magic values only from its corpus).
build_flags=()
case ${FUZZ_FAST:-} in
'' | 0) ;;
1) build_flags=(-s none --no-trace-compares) ;;
*) fail "FUZZ_FAST must be 1 or 0, got '$FUZZ_FAST'" ;;
esac
# FUZZ_DEV=1: the dev profile (opt-level 0, debug assertions, ASan still on). It builds in
# about 4 min instead of 16 (the release fuzz build is one single-threaded codegen unit per
# crate) but executes 50-170x fewer inputs per second: what scripts/test.sh uses for its smoke.
case ${FUZZ_DEV:-} in
'' | 0) ;;
1) build_flags+=(--dev) ;;
*) fail "FUZZ_DEV must be 1 or 0, got '$FUZZ_DEV'" ;;
esac

echo "==> building the fuzz targets (first build: several minutes)  [$(date -u +%T)]"
cargo fuzz build "${build_flags[@]}"

total=0
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t" "seeds/$t"
    log="artifacts/$t.log"
    mkdir -p artifacts
    echo "==> $t for $what  [$(date -u +%T)]"
    # -timeout: one input taking longer than 10 s is a hang; -rss_limit_mb: 2 GiB.
    if ! cargo fuzz run "${build_flags[@]}" "$t" "corpus/$t" "seeds/$t" -- \
        "${budget[@]}" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
        >"$log" 2>&1; then
        # The input's Debug dump is one very long line: keep lines short.
        grep -v '^[[:space:]]*\[' "$log" | tail -n 40 | cut -c1-300 >&2
        fail "$t crashed; the input is in fuzz/artifacts/$t/ (log: fuzz/$log)"
    fi
    # A target that rejects every input (e.g. a fixed-size input its seeds no longer fill)
    # runs without coverage: its executions test nothing, so that is a failure too.
    if grep -q 'no interesting inputs were found' "$log" || ! grep -q 'INITED cov:' "$log"; then
        fail "$t gains no coverage: every input is rejected before the code under test (log: fuzz/$log)"
    fi
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    echo "    $t: ${runs:-?} executions, no crash"
    total=$((total + ${runs:-0}))
done
echo "fuzz smoke: ${#targets[@]} targets, $total executions, no crash"
