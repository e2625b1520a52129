#!/usr/bin/env python3
"""Compares two directories of DBB analysis JSON (tests/bench/dbb/dbb_figures_dump) number by
number: a value beside its "uncertainty" (σ) may move by at most 1e-3 σ; so may the figures of a
test's least-squares fits, with the σ of a fit of n uniformly spread samples whose residual rms
is the test's fit_rms_um (σ² (AᵀA)⁻¹, AᵀA ≈ n/2 for a cos/sin column, n for a constant):
  centre_offset_um, harmonics amplitude_um   fit_rms·√(2/n)
  average_radial_error_um                    fit_rms/√n
  harmonics phase_deg                        that amplitude σ over the amplitude, in degrees
                                             (not compared for an amplitude below 1e-3 of its
                                             σ: its phase is then the rounding's);
every other number by at most 1e-9 relative, or 1e-8 absolute for a length in µm (a key ending
in _um: 1e-5 nm, far below the σ of any DBB figure) and 1e-12 absolute for the others near
zero; strings (effect names, verdicts) and the structure must be identical. Prints the largest moves; exits 1 on any
violation.

    compare_figures.py BEFORE_DIR AFTER_DIR
"""
import json
import math
import os
import re
import sys

worst = {"sigma": 0.0, "fit": 0.0, "rel": 0.0}
bad = []


def sigma_of(d):
    s = d.get("uncertainty") if isinstance(d, dict) else None
    return s if isinstance(s, (int, float)) and not isinstance(s, bool) and s > 0 else None


def fit_sigma(path, parent_a, test):
    """σ of a least-squares figure of the test (see the module's comment), None for others."""
    if test is None:
        return None
    rms, n = test.get("fit_rms_um"), test.get("sample_count")
    if not isinstance(rms, (int, float)) or not isinstance(n, int) or n <= 0 or rms <= 0:
        return None
    base = re.sub(r"\[\d+\]", "[]", path.split(".json.", 1)[-1])
    if base.endswith(".centre_offset_um[]") or base.endswith(".harmonics[].amplitude_um"):
        return rms * math.sqrt(2.0 / n)
    if base.endswith(".average_radial_error_um"):
        return rms / math.sqrt(n)
    if base.endswith(".harmonics[].phase_deg") and isinstance(parent_a, dict):
        amp = parent_a.get("amplitude_um")
        if isinstance(amp, (int, float)):
            s_amp = rms * math.sqrt(2.0 / n)
            if abs(amp) < 1e-3 * s_amp:
                return math.inf  # no phase to speak of
            return min(180.0, math.degrees(s_amp / abs(amp)))
    return None


def walk(a, b, path, parent_a, test=None):
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            bad.append(f"{path}: keys {sorted(a.keys() ^ b.keys())}")
            return
        if "fit_rms_um" in a and "sample_count" in a:
            test = a
        for k in a:
            walk(a[k], b[k], f"{path}.{k}", a, test)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            bad.append(f"{path}: length {len(a)} != {len(b)}")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            walk(x, y, f"{path}[{i}]", parent_a, test)
    elif isinstance(a, bool) or isinstance(b, bool) or isinstance(a, str) or a is None:
        if a != b:
            bad.append(f"{path}: {a!r} != {b!r}")
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)):
        d = abs(a - b)
        s = sigma_of(parent_a)
        fs = fit_sigma(path, parent_a, test)
        if path.endswith(".value") and s is not None:
            worst["sigma"] = max(worst["sigma"], d / s)
            if d > 1e-3 * s:
                bad.append(f"{path}: {a} -> {b} ({d / s:.3g} σ)")
        elif fs is not None:
            if math.isinf(fs):
                return
            worst["fit"] = max(worst["fit"], d / fs)
            if d > 1e-3 * fs:
                bad.append(f"{path}: {a} -> {b} ({d / fs:.3g} σ of the fit)")
        else:
            rel = d / max(abs(a), abs(b)) if d > 0 else 0.0
            floor = 1e-8 if re.search(r"_um(\[\d+\])?$", path) else 1e-12
            worst["rel"] = max(worst["rel"], rel if d > floor else 0.0)
            if d > floor and rel > 1e-9:
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
          f"{worst['fit']:.3g} σ of a fitted figure, {worst['rel']:.3g} relative elsewhere "
          f"(beyond the absolute floors); "
          f"{len(bad)} violations")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
