#!/usr/bin/env python3
"""Compares two directories of DBB analysis JSON (tests/bench/dbb/dbb_figures_dump) number by
number: a value beside its "uncertainty" (σ) may move by at most 1e-3 σ, every other number by
at most 1e-9 relative (1e-12 absolute near zero); strings (effect names, verdicts) and the
structure must be identical. Prints the largest move in σ; exits 1 on any violation.

    compare_figures.py BEFORE_DIR AFTER_DIR
"""
import json
import os
import sys

worst = {"sigma": 0.0, "rel": 0.0}
bad = []


def sigma_of(d):
    s = d.get("uncertainty") if isinstance(d, dict) else None
    return s if isinstance(s, (int, float)) and not isinstance(s, bool) and s > 0 else None


def walk(a, b, path, parent_a):
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            bad.append(f"{path}: keys {sorted(a.keys() ^ b.keys())}")
            return
        for k in a:
            walk(a[k], b[k], f"{path}.{k}", a)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            bad.append(f"{path}: length {len(a)} != {len(b)}")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            walk(x, y, f"{path}[{i}]", parent_a)
    elif isinstance(a, bool) or isinstance(b, bool) or isinstance(a, str) or a is None:
        if a != b:
            bad.append(f"{path}: {a!r} != {b!r}")
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)):
        d = abs(a - b)
        s = sigma_of(parent_a)
        if path.endswith(".value") and s is not None:
            worst["sigma"] = max(worst["sigma"], d / s)
            if d > 1e-3 * s:
                bad.append(f"{path}: {a} -> {b} ({d / s:.3g} σ)")
        else:
            rel = d / max(abs(a), abs(b)) if d > 0 else 0.0
            worst["rel"] = max(worst["rel"], rel if d > 1e-12 else 0.0)
            if d > 1e-12 and rel > 1e-9:
                bad.append(f"{path}: {a} -> {b} (relative {rel:.3g})")
    else:
        bad.append(f"{path}: {a!r} != {b!r}")


def main():
    before, after = sys.argv[1], sys.argv[2]
    names = sorted(os.listdir(before))
    if sorted(os.listdir(after)) != names:
        bad.append("the two directories hold different cases")
    for n in names:
        if os.path.exists(os.path.join(after, n)):
            with open(os.path.join(before, n)) as fa, open(os.path.join(after, n)) as fb:
                walk(json.load(fa), json.load(fb), n, None)
    for line in bad[:50]:
        print(line)
    print(f"{len(names)} cases; largest move {worst['sigma']:.3g} σ of a diagnosed value, "
          f"{worst['rel']:.3g} relative elsewhere; {len(bad)} violations")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
