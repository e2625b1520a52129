#!/usr/bin/python3
"""The uncertainty of DBB figures (docs/methods.md §16.4) against an independent Monte Carlo
written here from the definitions with numpy (no kinemetric code): the least-squares circle by
Gauss-Newton on the orthogonal distances, circularity = range of its residuals, average radial
error R0 - R, and for a pair the common least-squares circle, G(b) = range of both traces'
residuals about it, H = largest difference of one trace's residual and the other's interpolated
at its angle (periodically), both ways.

Files: R 150 mm, 3 600 readings a turn, a 7.3 µm oval (range) and a 2.1 µm third harmonic (range),
u_reading_um 0.37, u_bar_length_um 0.9, u_bar_temperature_c 0.3, α 11.2 ppm/K. Tolerance: each
U within 10 % of the independent one (M = 4 000 here, M = 1 000 in kinemetric: the two
statistical errors together are ~3 % of U). Physics checks: with only u_bar_length_um stated,
U(average_radial_error_um) = 2·u·L/R within 4 % (a cone test, L/R = 150/144) and U(circularity)
below 1 nm.

  dbb_uncertainty_test.py --bin DIR
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

R_MM = 150.0
N = 3600
OVAL = 7.3 / 2.0
THIRD = 2.1 / 2.0


def trace(direction, seed):
    s = 1.0 if direction == "ccw" else -1.0
    angle = s * 0.1 * np.arange(N)
    th = np.radians(angle)
    rng = np.random.default_rng(seed)
    dr = OVAL * np.cos(2 * th - 0.4) + THIRD * np.cos(3 * th + 1.1) + rng.normal(0, 0.1, N)
    if direction == "cw":
        dr += 0.6 * np.sign(np.sin(th))  # a reversal step: H of some µm
    return angle, dr


def write(path, direction, angle, dr, header, radius=R_MM, bar=R_MM, z=0.0):
    with open(path, "w") as f:
        f.write("# format: kinemetric-dbb/1\n# machine_id: mc-check\n# test_id: xy\n")
        f.write("# direction: %s\n# bar_length_mm: %g\n# radius_mm: %g\n" % (direction, bar, radius))
        f.write("# z_offset_mm: %g\n# centre_mm: 0, 0, 0\n# feed_mm_min: 1000\n" % z)
        for k, v in header.items():
            f.write("# %s: %s\n" % (k, v))
        f.write("angle_deg,dr_um\n")
        for a, d in zip(angle, dr):
            f.write("%.4f,%.6f\n" % (a, d))


def ls_circle(x, y):
    c = np.array([0.0, 0.0, np.hypot(x, y).mean()])
    for _ in range(50):
        vx, vy = x - c[0], y - c[1]
        d = np.hypot(vx, vy)
        j = np.column_stack([-vx / d, -vy / d, -np.ones_like(d)])
        step = np.linalg.lstsq(j, -(d - c[2]), rcond=None)[0]
        c += step
        if np.linalg.norm(step) < 1e-10:
            break
    return c


def figures(traces, r_um):
    """[circularity, average radial error] per trace, then H and G(b) for two traces."""
    out, res, ang = [], [], []
    for th, dev in traces:
        rho = r_um + dev
        x, y = rho * np.cos(th), rho * np.sin(th)
        c = ls_circle(x, y)
        e = np.hypot(x - c[0], y - c[1]) - c[2]
        out += [e.max() - e.min(), c[2] - r_um]
    if len(traces) == 2:
        xs, ys = [], []
        for th, dev in traces:
            rho = r_um + dev
            xs.append(rho * np.cos(th))
            ys.append(rho * np.sin(th))
        c = ls_circle(np.concatenate(xs), np.concatenate(ys))
        for (th, _), x, y in zip(traces, xs, ys):
            res.append(np.hypot(x - c[0], y - c[1]) - c[2])
            ang.append(np.mod(th, 2 * np.pi))
        both = np.concatenate(res)
        h = 0.0
        for a, b in ((0, 1), (1, 0)):
            order = np.argsort(ang[b])
            other = np.interp(ang[a], ang[b][order], res[b][order], period=2 * np.pi)
            h = max(h, np.abs(res[a] - other).max())
        out += [h, both.max() - both.min()]
    return out


def independent_mc(traces, u, alpha, bar_mm, factor, r_um, draws=4000, seed=7):
    rng = np.random.default_rng(seed)
    ys = []
    for _ in range(draws):
        common = rng.normal(0, u["u_bar_length_um"]) + alpha * bar_mm * 1e-3 * rng.normal(
            0, u["u_bar_temperature_c"])
        noisy = [(th, factor * (dr + rng.normal(0, u["u_reading_um"], dr.size) + common))
                 for th, dr in traces]
        ys.append(figures(noisy, r_um))
    return 2.0 * np.std(np.array(ys), axis=0, ddof=1)


def analyze(bin_dir, paths):
    out = subprocess.run([os.path.join(bin_dir, "kinemetric"), "dbb", "analyze", *paths, "--json"],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def check(name, got, want, rel, problems):
    ok = abs(got - want) <= rel * want
    print("%-46s kinemetric U %.4f µm, independent %.4f µm (%+.1f %%) %s"
          % (name, got, want, 100.0 * (got - want) / want, "ok" if ok else "FAIL"))
    if not ok:
        problems.append(name)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    args = ap.parse_args()
    problems = []
    u = {"u_reading_um": 0.37, "u_bar_length_um": 0.9, "u_bar_temperature_c": 0.3}
    header = dict(u, bar_expansion_ppm_per_k=11.2)
    with tempfile.TemporaryDirectory() as tmp:
        traces, paths = [], []
        for direction, seed in (("cw", 1), ("ccw", 2)):
            angle, dr = trace(direction, seed)
            paths.append(os.path.join(tmp, direction + ".txt"))
            write(paths[-1], direction, angle, dr, header)
            traces.append((np.radians(angle), dr))
        got = analyze(args.bin, paths)
        want = independent_mc(traces, u, 11.2, R_MM, 1.0, R_MM * 1e3)
        for i, t in enumerate(got["tests"]):
            f = t["uncertainty"]["figures"]
            check("%s circularity_um" % t["direction"], f["circularity_um"]["U_um"], want[2 * i],
                  0.10, problems)
            check("%s average_radial_error_um" % t["direction"],
                  f["average_radial_error_um"]["U_um"], want[2 * i + 1], 0.10, problems)
            check("%s circular_deviation_um = circularity" % t["direction"],
                  f["circular_deviation_um"]["U_um"], f["circularity_um"]["U_um"], 1e-9, problems)
        p = got["pairs"][0]["uncertainty"]["figures"]
        check("circular_hysteresis_um", p["circular_hysteresis_um"]["U_um"], want[4], 0.10,
              problems)
        check("bidirectional_circular_deviation_um",
              p["bidirectional_circular_deviation_um"]["U_um"], want[5], 0.10, problems)

        # Only the bar length: U(R0 − R) = 2·u·L/R on a cone test, the circularity unmoved.
        angle, dr = trace("ccw", 3)
        cone = os.path.join(tmp, "cone.txt")
        write(cone, "ccw", angle, dr, {"u_bar_length_um": 0.9}, radius=144.0, bar=150.0, z=42.0)
        f = analyze(args.bin, [cone])["tests"][0]["uncertainty"]["figures"]
        check("cone: average_radial_error_um = 2·u·L/R", f["average_radial_error_um"]["U_um"],
              2 * 0.9 * 150.0 / 144.0, 0.04, problems)
        # u_bar_temperature_c without the bar's expansion coefficient: refused, naming the key.
        bad = os.path.join(tmp, "no_alpha.txt")
        write(bad, "ccw", angle, dr, {"u_bar_temperature_c": 0.3})
        run = subprocess.run([os.path.join(args.bin, "kinemetric"), "dbb", "analyze", bad],
                             capture_output=True, text=True)
        print("u_bar_temperature_c without α: exit %d, %s" % (run.returncode, run.stderr.strip()))
        if run.returncode != 2 or "u_bar_temperature_c" not in run.stderr:
            problems.append("u_bar_temperature_c without bar_expansion_ppm_per_k")
        circ = f["circularity_um"]["U_um"]
        print("cone: U(circularity_um) %.2e µm (< 1e-3)" % circ)
        if not circ < 1e-3:
            problems.append("cone circularity")
    if problems:
        print("FAILED: " + ", ".join(problems))
        return 1
    print("all within tolerance")
    return 0


if __name__ == "__main__":
    sys.exit(main())
