#!/usr/bin/env bash
# The Python package's tests (README; a step of scripts/test.sh): a virtual environment with
# maturin, pytest, numpy and Pinocchio (`pin`), one build of the abi3 wheel, its installation,
# then pytest. With CI=true a missing tool is a failure, never a skip.
# KINCAL_WHEEL_PROFILE: the cargo profile of the wheel (default release; scripts/test.sh uses
# dev, whose core and nalgebra are optimised (Cargo.toml), with debug assertions and overflow
# checks on: the same bindings, without a full release build of every dependency).
set -euo pipefail
cd "$(dirname "$0")"
PY_DIR=$PWD
ROOT=$(cd .. && pwd)
CI=${CI:-false}
fail() { printf 'error: %s\n' "$*" >&2; exit 1; }
step() { printf '\n--> %s  [%s]\n' "$*" "$(date -u +%T)"; }

PYTHON=${PYTHON:-python3}
command -v "$PYTHON" >/dev/null 2>&1 || fail "$PYTHON is missing (Debian: apt-get install python3 python3-venv)"
"$PYTHON" -c 'import sys; sys.exit(sys.version_info < (3, 8))' \
    || fail "$PYTHON is older than 3.8 (the wheel is abi3-py38)"
command -v cargo >/dev/null 2>&1 || fail "cargo is missing (install Rust with rustup)"

# The package shares the repository's target/ (dependencies built once) and keeps its
# virtual environment there too, out of the source tree.
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$ROOT/target}
VENV=${KINCAL_VENV:-$CARGO_TARGET_DIR/python-venv}
if [ ! -x "$VENV/bin/python" ]; then
    step "virtual environment $VENV"
    "$PYTHON" -m venv "$VENV" || fail "cannot create a virtual environment (Debian: apt-get install python3-venv)"
fi
step "maturin, pytest, numpy, pin"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check maturin pytest numpy pin \
    || fail "pip could not install maturin pytest numpy pin"

step "format and lints (python/ is a workspace of its own)"
cargo fmt --manifest-path Cargo.toml -- --check
PROFILE=${KINCAL_WHEEL_PROFILE:-release}
case $PROFILE in
release | dev) ;;
*) fail "KINCAL_WHEEL_PROFILE must be release or dev, got '$PROFILE'" ;;
esac
PYO3_PYTHON="$VENV/bin/python" cargo clippy -q --manifest-path Cargo.toml --profile "$PROFILE" -- -D warnings

step "wheel (maturin build --profile $PROFILE, abi3)"
rm -rf "$CARGO_TARGET_DIR/wheels"
"$VENV/bin/maturin" build --profile "$PROFILE" --quiet --interpreter "$VENV/bin/python" \
    --out "$CARGO_TARGET_DIR/wheels"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps \
    "$CARGO_TARGET_DIR"/wheels/kincal-*.whl

step "the kincal binary the tests compare with"
if [ -z "${KINCAL_BIN:-}" ]; then
    (cd "$ROOT" && cargo build -q -p kincal-cli)
    export KINCAL_BIN=$CARGO_TARGET_DIR/debug/kincal
fi

step "pytest"
# Not `python -m pytest` from here: that would import ./kincal (the sources) instead of the
# installed wheel.
cd "$CARGO_TARGET_DIR"
CI=$CI "$VENV/bin/pytest" -q -p no:cacheprovider "$PY_DIR/tests"
