#!/usr/bin/env bash
# The one test command (README): installs what is missing on a fresh Debian machine (as
# root), builds everything and runs every test. With CI=true a missing tool is a failure,
# never a skip.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
CI=${CI:-false}
export CARGO_TERM_COLOR=${CARGO_TERM_COLOR:-never}
# A clean CI build gains nothing from incremental caches, which would double the debug
# target's size on disk.
if [ "$CI" = true ]; then export CARGO_INCREMENTAL=${CARGO_INCREMENTAL:-0}; fi

# Each step prints the wall clock, so a slow CI log shows where its time went.
step() { printf '\n==> %s  [%s]\n' "$*" "$(date -u +%T)"; }
fail() { printf 'error: %s\n' "$*" >&2; exit 1; }

need_apt() { # need_apt COMMAND PACKAGE...
    local cmd=$1; shift
    command -v "$cmd" >/dev/null 2>&1 && return 0
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        step "installing $* (for $cmd)"
        if [ -z "${APT_UPDATED:-}" ]; then apt-get update -qq; APT_UPDATED=1; fi
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
    fi
    command -v "$cmd" >/dev/null 2>&1 || fail "$cmd is missing and could not be installed (apt-get install $*)"
}

step "tools"
# The whole run needs about 4 GB under target/ and fuzz/target/; say so up front rather than
# fail half-way with "No space left on device".
free_kb=$(df -Pk . | awk 'NR==2 {print $4}')
if [ -n "$free_kb" ] && [ "$free_kb" -lt 4500000 ]; then
    printf 'warning: only %s MB free on this disk; the full test run needs about 4 GB\n' \
        "$((free_kb / 1024))" >&2
fi
command -v cargo >/dev/null || fail "cargo is missing (install Rust with rustup)"
need_apt g++ g++
need_apt octave-cli octave liboctave-dev
need_apt mkoctfile liboctave-dev
need_apt gnuplot gnuplot-nox   # Octave's headless figures
need_apt python3 python3 python3-venv   # python/run.sh: the wheel's venv (pip brings the rest)
if ! python3 -c 'import ensurepip' >/dev/null 2>&1; then
    # Debian's python3 lacks `venv`'s pip without python3-venv.
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        step "installing python3-venv"
        if [ -z "${APT_UPDATED:-}" ]; then apt-get update -qq; APT_UPDATED=1; fi
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
    fi
    python3 -c 'import ensurepip' >/dev/null 2>&1 || fail "python3 cannot create virtual environments (apt-get install python3-venv)"
fi
if ! rustup target list --installed 2>/dev/null | grep -q thumbv7em-none-eabihf; then
    rustup target add thumbv7em-none-eabihf || fail "cannot add the thumbv7em-none-eabihf target"
fi
rustup component list --installed 2>/dev/null | grep -q '^rustfmt' || rustup component add rustfmt clippy

step "format and lints"
cargo fmt --all -- --check
cargo clippy --workspace --all-targets -- -D warnings
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --workspace

step "no_std core for a bare-metal target"
cargo build -p kincal --target thumbv7em-none-eabihf

step "Python tools the Rust tests use (mcap: the independent ROS 2 bag writer)"
# The same venv python/run.sh uses later (target/python-venv).
VENV=${KINCAL_VENV:-${CARGO_TARGET_DIR:-$ROOT/target}/python-venv}
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV" || fail "cannot create $VENV (apt-get install python3-venv)"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check mcap \
    || fail "pip could not install mcap"
export KINCAL_PYTHON=$VENV/bin/python

# One release build of the CLI serves every later step: the real-data studies too slow
# unoptimised (cli/tests/real_data_hilti.rs runs it from the debug test binary), the C++
# consumer's model-file test, the Octave cross-checks and the Python tests.
step "release build of the CLI (for the slow real-data studies and the later steps)"
cargo build --release -p kincal-cli
TARGET_DIR=${CARGO_TARGET_DIR:-$ROOT/target}
case $TARGET_DIR in /*) ;; *) TARGET_DIR=$ROOT/$TARGET_DIR ;; esac
export KINCAL_RELEASE_BIN=$TARGET_DIR/release/kincal
export KINCAL_BIN=${KINCAL_BIN:-$KINCAL_RELEASE_BIN}

step "Rust unit, integration and doc tests"
cargo test --workspace

# The Python tests build their wheel in the dev profile (python/run.sh): the same bindings
# with debug assertions on, without a second full release build of every dependency.
export KINCAL_WHEEL_PROFILE=${KINCAL_WHEEL_PROFILE:-dev}
# The fuzz smoke builds its targets in the dev profile (fuzz/smoke.sh: 4 min instead of 16).
export FUZZ_DEV=${FUZZ_DEV:-1}
# The panic-never proof at every firmware opt-level and the host's 3 (which also runs
# tests/cpp/panic_never.c); host:s, the fifth of the full matrix (`bash
# tests/cpp/panic_never.sh`), is left out to keep the run short: each build is 4-6 min.
export KINCAL_PANIC_NEVER_CONFIGS=${KINCAL_PANIC_NEVER_CONFIGS:-"thumbv7em-none-eabihf:3 host:3 thumbv7em-none-eabihf:s thumbv7em-none-eabihf:z"}

for extra in tests/cpp/run.sh matlab/tests/run.sh python/run.sh fuzz/smoke.sh; do
    if [ -f "$extra" ]; then
        step "$extra"
        bash "$extra"
    fi
done

step "all tests passed"
du -sh target fuzz/target 2>/dev/null || true
