#!/usr/bin/env bash
# kincal's firmware path (prepared FK, prepared joint Jacobian) against Pinocchio in one
# process: see tests/cpp/bench_pinocchio.cpp for what is compared and how.
#
# NOT part of CI or tests/cpp/run.sh: it needs Pinocchio from pip (a few hundred MB) and its
# figures depend on the machine's load. Run by hand:
#
#   python3 -m venv target/pinvenv && target/pinvenv/bin/pip install pin cmeel-eigen
#   tests/cpp/bench_pinocchio.sh            # or PYTHON=/path/to/venv/bin/python ...
#
# Environment: PYTHON (default target/pinvenv/bin/python of the workspace, else python3): an
# interpreter with `pin` and `cmeel-eigen` installed (their headers live under the pip
# package's `cmeel.prefix`); CARGO_TARGET_DIR (default ./target); CXX (default g++).
# Builds kincal-ffi in release, compiles the benchmark with -O3 against the staticlib and
# Pinocchio's headers, and runs it (exit 1 when kincal and Pinocchio disagree beyond 1e-12).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
[[ $target = /* ]] || target=$PWD/$target
CXX=${CXX:-g++}
python=${PYTHON:-}
if [[ -z $python ]]; then
    python=$target/pinvenv/bin/python
    [[ -x $python ]] || python=python3
fi
prefix=$("$python" -m cmeel cmake 2>/dev/null | tr ':' '\n' | head -n1) ||
    { echo "bench_pinocchio.sh: no cmeel prefix: pip install pin cmeel-eigen into $python's environment" >&2; exit 1; }
[[ -d $prefix/include/pinocchio ]] ||
    { echo "bench_pinocchio.sh: Pinocchio headers not under $prefix (pip install pin)" >&2; exit 1; }
[[ -d $prefix/include/eigen3 ]] ||
    { echo "bench_pinocchio.sh: Eigen headers not under $prefix (pip install cmeel-eigen)" >&2; exit 1; }

(cd "$root" && CARGO_TARGET_DIR=$target cargo build -q -p kincal-ffi --release)
exe=$target/bench_pinocchio
# Pinocchio's own compile definitions (its CMake config), minus template instantiation: its
# templates are compiled here, with the same optimisation as the call sites.
"$CXX" -std=c++17 -O3 -DNDEBUG \
    -DBOOST_MPL_LIMIT_LIST_SIZE=30 -DBOOST_MPL_LIMIT_VECTOR_SIZE=30 \
    -DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS -DBOOST_FUSION_INVOKE_MAX_ARITY=12 \
    -I"$root/include" -isystem "$prefix/include" -isystem "$prefix/include/eigen3" \
    "$here/bench_pinocchio.cpp" "$target/release/libkincal.a" -lpthread -ldl -lm -o "$exe"
"$exe"
