#!/usr/bin/env bash
# Octave tests of the Matlab/Octave toolbox; the project's test command (scripts/test.sh)
# runs this script.
#
#  1. builds the C ABI staticlib (cargo build --release -p kincal-ffi) and the CLI used by
#     the cross-checks (cargo build --release -p kincal-cli);
#  2. builds a second gateway, with -DKINCAL_TEST_PANIC, against the debug staticlib with the
#     test-panic export (the test that a Rust panic reaches Octave as kincal:panic);
#  3. builds the MEX gateway with make_kincal.m (mkoctfile --mex);
#  4. runs matlab/tests/run_tests.m in octave-cli (gateway errors, kinematics against
#     independent code, CSV rules, identification, cross-checks against the CLI, the three
#     workflow scripts headless); a failing test makes this script fail (with CI=true a
#     skipped test too).
#
# Installs nothing: scripts/test.sh installs Octave (apt-get install octave liboctave-dev;
# gnuplot, which octave-cli draws the figures with, comes as one of Octave's recommended
# packages). Without octave-cli, mkoctfile or gnuplot this script fails when CI=true and
# skips otherwise.
# Environment: CARGO_TARGET_DIR (default ./target); KINCAL_TEST_FILTER runs only the tests
# whose "file/name" contains it; KINCAL_OUT is where the workflow scripts write (default: a
# temporary folder).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
cd "$root"

for tool in octave-cli:"octave liboctave-dev" mkoctfile:liboctave-dev gnuplot:gnuplot-nox; do
    name=${tool%%:*}
    package=${tool#*:}
    if ! command -v "$name" >/dev/null 2>&1; then
        if [[ ${CI:-} == true ]]; then
            echo "matlab/tests/run.sh: FAILED: $name is required (CI=true); install it with" \
                "apt-get install $package" >&2
            exit 1
        fi
        echo "matlab/tests/run.sh: SKIP: $name not available (apt-get install $package)"
        exit 0
    fi
done

printf '\n=== cargo build --release -p kincal-ffi -p kincal-cli  [%s]\n' "$(date -u +%T)"
cargo build --release -p kincal-ffi -p kincal-cli

out=${KINCAL_OUT:-}
cleanup=
if [[ -z $out ]]; then
    out=$(mktemp -d "${TMPDIR:-/tmp}/kincal-matlab-test.XXXXXX")
    cleanup=$out
fi
trap '[[ -n $cleanup ]] && rm -rf "$cleanup"' EXIT
export KINCAL_OUT=$out

target=${CARGO_TARGET_DIR:-$root/target}
[[ $target = /* ]] || target=$root/$target
printf '\n=== the test-panic gateway (cargo build -p kincal-ffi --features test-panic)  [%s]\n' "$(date -u +%T)"
cargo build -p kincal-ffi --features test-panic
mkdir -p "$out/panic_mex"
cp "$target/debug/libkincal.a" "$out/panic_mex/libkincal-test-panic.a"
mkoctfile --mex -DKINCAL_TEST_PANIC -I"$root/include" -o "$out/panic_mex/kincal_mex_panic.mex" \
    "$root/matlab/private/kincal_mex.c" "$out/panic_mex/libkincal-test-panic.a"
rm -f "$out/panic_mex/"*.o
export KINCAL_PANIC_MEX=$out/panic_mex/kincal_mex_panic.mex

printf '\n=== octave-cli: make_kincal, run_tests (outputs in %s)  [%s]\n' "$out" "$(date -u +%T)"
cd "$root/matlab"
# tempname() in the tests then lands in a folder of the temporary folder this script removes;
# the check after the run fails if a test left anything there or in the system's folder.
system_tmp=${TMPDIR:-/tmp}
mkdir -p "$out/tmp"
export TMPDIR=$out/tmp
start_marker=$out/start-marker
touch "$start_marker"
# The test-panic test panics on purpose: its message is expected, a backtrace of it is noise.
export RUST_BACKTRACE=0
# The filter is passed through the environment, never spliced into the Octave code.
octave-cli -q --norc --no-history --eval \
    "make_kincal('all'); addpath('tests'); run_tests('filter', getenv('KINCAL_TEST_FILTER'), 'exit', true);"

# Issue #19 item 8: a run leaves no temporary file behind. run_tests gives each test a fresh
# TMPDIR and removes it; anything in $TMPDIR now, or a new Octave temporary file (oct-*) in
# the system's temporary folder, is a leak.
left=$(find "$TMPDIR" -mindepth 1 -maxdepth 1 -printf '%f\n' | head -n 20)
leaked=$(find "$system_tmp" -mindepth 1 -maxdepth 1 -name 'oct-*' -user "$(id -u)" \
    -newer "$start_marker" -printf '%f\n' 2>/dev/null | head -n 20)
if [[ -n $left || -n $leaked ]]; then
    echo "matlab/tests/run.sh: FAILED: the run left temporary files:" ${left:+"in \$TMPDIR: $left"} \
        ${leaked:+"in $system_tmp: $leaked"} >&2
    exit 1
fi
echo "matlab/tests/run.sh: no temporary file left behind"
