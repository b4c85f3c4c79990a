#!/usr/bin/env python3
"""Compares two dumps of core/tests/calibration_fingerprint.rs figure by figure.

Write each dump with the build to compare:
    KINCAL_FINGERPRINT_DUMP=old.txt cargo test --release -p kincal --test calibration_fingerprint
then run `scripts/compare_fingerprint_dumps.py old.txt new.txt`. The texts must have the same
shape (the same words, the same count of numbers); the script prints the largest relative
difference of the numbers above 1e-9 in magnitude, the largest absolute difference of the
others, and every differing integer (iteration counts, ranks). Exit status 1 when the shapes
differ or a relative difference exceeds --rtol (default 1e-12).
"""
import argparse
import re
import sys

NUMBER = re.compile(r"-?(?:\d+\.\d*(?:e-?\d+)?|\d+e-?\d+|inf|NaN|\d+)")


def tokens(text):
    numbers = NUMBER.findall(text)
    return NUMBER.sub("#", text), numbers


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--rtol", type=float, default=1e-12)
    args = ap.parse_args()
    shape_old, old = tokens(open(args.old).read())
    shape_new, new = tokens(open(args.new).read())
    if shape_old != shape_new or len(old) != len(new):
        print("the dumps differ in shape (not only in figures)")
        return 1
    max_rel = max_abs = 0.0
    worst = None
    changed_ints = []
    floats = same = 0
    for a, b in zip(old, new):
        if a == b:
            same += 1
        is_float = any(c in a for c in ".eiN") or any(c in b for c in ".eiN")
        if not is_float:
            if a != b:
                changed_ints.append((a, b))
            continue
        floats += 1
        x, y = float(a), float(b)
        if x == y or (x != x and y != y):
            continue
        scale = max(abs(x), abs(y))
        if scale > 1e-9:
            rel = abs(x - y) / scale
            if rel > max_rel:
                max_rel, worst = rel, (a, b)
        else:
            max_abs = max(max_abs, abs(x - y))
    print(f"{len(old)} numbers ({floats} floats), {same} identical")
    print(f"largest relative difference (|x| > 1e-9): {max_rel:.3e} {worst or ''}")
    print(f"largest absolute difference (|x| <= 1e-9): {max_abs:.3e}")
    print(f"integers that differ: {len(changed_ints)} {changed_ints[:10]}")
    return 0 if max_rel <= args.rtol else 1


if __name__ == "__main__":
    sys.exit(main())
