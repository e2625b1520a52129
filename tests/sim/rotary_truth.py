#!/usr/bin/python3
"""Independent truth simulator of R-test files of a trunnion table's rotary axes
(`# format: kinemetric-rotary/1`, docs/formats.md §1.10), written straight from the definitions
of the location errors in the issue and docs/methods.md §17 with Rodrigues rotation matrices.
Shares no code with analysis/rotary/.

Definitions (machine coordinates, mm; errors µm and µrad):
  AC: the actual A line crosses X = 0 at (0, y_A + YOA, z_A + ZOA), direction (1, COA, -BOA)
  BC: the actual B line crosses Y = 0 at (x_B + XOB, 0, z_B + ZOB), direction (-COB, 1, AOB)
  C:  at zero tilt the actual C line crosses Z = 0 at (x_C + XOC, y_C + YOC, 0),
      direction (BOC, -AOC, 1)
  directions normalised; a positive angle turns the table right-handed about the axis.
  sphere(t, c) = T_tilt(t)(T_C(c)(s)), T(x) = q + R(u, angle)(x - q); the nest is at the same
  composition about the nominal lines; the reading is 1000 (actual - nominal) µm + noise, and 0 at
  the first pose (zero angles), where the sensors are zeroed.

Hidden position-dependent errors (--hidden, docs/methods.md §17.6, written from the physical
definitions there):
  c_angle: the C axis turns to c + e(c), e(c) = 18.3 cos c - 12.7 sin 2c + 9.1 c  µrad (c in rad)
  drift:   the C line's crossing point moves by (+7.3, -5.1) µm per hour of time_s (XOC, YOC)
  x_scale: not a rotary-axis effect (no candidate models it): the X axis holding the nest
           reads 30 µm/m long, the X reading gains 0.03 µm per mm of the nest's X travel
  tilt_radial: not a candidate either: the tilt line's point moves along Z by 3 µm × sin 3t
  the sensors are zeroed at the first pose: every reading is the displacement minus the
  displacement at the first pose.

First-order uncertainty (--gum-u U, docs/methods.md §17.8): J, the derivatives of the 3N
readings with respect to the eight errors, by central differences of this file's own forward model
at the truth (step 0.1 µm / µrad), and u_gum = U sqrt(diag((J^T J)^-1)) for readings of standard
uncertainty U each (all eight errors must be determined by the poses).

usage: rotary_truth.py --kinematics AC|BC --poses full|tilt0|on_axis|random
                       [--seed N] [--noise UM] [--count N] [--hidden c_angle,drift]
                       [--dt SECONDS] [--gum-u UM] --out FILE
Writes FILE and prints the true errors as JSON: {"errors": {"YOA": 13.7, ...}, "hidden": {...}}
(with --gum-u also "u_gum": {"YOA": 0.21, ...}).
"""
import argparse
import json
import math

import numpy as np

TRUTH = {
    "AC": {"YOA": 13.7, "ZOA": -8.4, "BOA": -23.1, "COA": 17.6,
           "XOC": -11.3, "YOC": 7.9, "AOC": 19.4, "BOC": -14.2},
    "BC": {"XOB": -9.6, "ZOB": 12.3, "AOB": 21.7, "COB": -16.8,
           "XOC": 6.4, "YOC": -12.9, "AOC": -18.3, "BOC": 11.1},
}
SETUP = {
    "AC": {"tilt": (8.25, 61.4), "c": (1.7, -2.35), "sphere": (148.6, 23.9, 118.2)},
    "BC": {"tilt": (-5.15, 57.3), "c": (3.2, -1.45), "sphere": (-41.7, 156.3, 108.9)},
}


def rodrigues(u, angle):
    u = np.asarray(u, dtype=float)
    u = u / np.linalg.norm(u)
    k = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def lines(kin, setup, e):
    """(point, direction) of the tilt line and of the C line for errors e (µm, µrad)."""
    t, c = setup["tilt"], setup["c"]
    if kin == "AC":
        tilt = (np.array([0.0, t[0] + 1e-3 * e["YOA"], t[1] + 1e-3 * e["ZOA"]]),
                np.array([1.0, 1e-6 * e["COA"], -1e-6 * e["BOA"]]))
    else:
        tilt = (np.array([t[0] + 1e-3 * e["XOB"], 0.0, t[1] + 1e-3 * e["ZOB"]]),
                np.array([-1e-6 * e["COB"], 1.0, 1e-6 * e["AOB"]]))
    cline = (np.array([c[0] + 1e-3 * e["XOC"], c[1] + 1e-3 * e["YOC"], 0.0]),
             np.array([1e-6 * e["BOC"], -1e-6 * e["AOC"], 1.0]))
    return tilt, cline


HIDDEN = {"c_angle": {"cos1_urad": 18.3, "sin2_urad": -12.7, "scale_urad_per_rad": 9.1},
          "drift": {"XOC_um_per_h": 7.3, "YOC_um_per_h": -5.1}}


def c_angle_error(hidden, c_rad):
    """Angular positioning error of C, rad."""
    if "c_angle" not in hidden:
        return 0.0
    h = HIDDEN["c_angle"]
    return 1e-6 * (h["cos1_urad"] * math.cos(c_rad) + h["sin2_urad"] * math.sin(2.0 * c_rad)
                   + h["scale_urad_per_rad"] * c_rad)


def drifted(errors, hidden, hours):
    e = dict(errors)
    if "drift" in hidden:
        e["XOC"] = e["XOC"] + HIDDEN["drift"]["XOC_um_per_h"] * hours
        e["YOC"] = e["YOC"] + HIDDEN["drift"]["YOC_um_per_h"] * hours
    return e


def turn(line, angle, x):
    q, u = line
    return q + rodrigues(u, angle) @ (x - q)


def position(kin, setup, e, tilt_deg, c_deg, c_error=0.0):
    tilt, cline = lines(kin, setup, e)
    s = np.array(setup["sphere"], dtype=float)
    c = math.radians(c_deg) + c_error
    return turn(tilt, math.radians(tilt_deg), turn(cline, c, s))


def displacement(kin, setup, truth, zero, hidden, t, c, hours):
    """µm, actual - nominal, with the hidden effects at this pose and time."""
    e = drifted(truth, hidden, hours)
    if "tilt_radial" in hidden:
        z = "ZOA" if kin == "AC" else "ZOB"
        e[z] = e[z] + 3.0 * math.sin(3.0 * math.radians(t))
    actual = position(kin, setup, e, t, c,
                      c_angle_error(hidden, math.radians(c)))
    nominal = position(kin, setup, zero, t, c)
    d = 1e3 * (actual - nominal)
    if "x_scale" in hidden:
        d[0] += 0.03 * (nominal[0] - setup["sphere"][0])
    return d


def poses(kind, rng, count):
    cs = [30.0 * i for i in range(12)]
    if kind == "full":
        out = [(t, c) for t in (-90.0, -45.0, 0.0, 45.0, 90.0) for c in cs]
    elif kind in ("tilt0", "on_axis"):
        out = [(0.0, c) for c in cs] if kind == "tilt0" else \
              [(t, c) for t in (-90.0, -45.0, 0.0, 45.0, 90.0) for c in cs]
    else:  # random poses over the working range
        out = [(rng.uniform(-110.0, 110.0), rng.uniform(-360.0, 360.0)) for _ in range(count)]
    out = [p for p in out if p != (0.0, 0.0)]
    return [(0.0, 0.0)] + out


def first_order_u(kin, setup, truth, pose_list, u):
    """u * sqrt(diag((J^T J)^-1)), J by central differences of the zeroed readings."""
    zero = {k: 0.0 for k in truth}
    names = list(truth)

    def readings(e):
        d = [displacement(kin, setup, e, zero, [], t, c, 0.0) for t, c in pose_list]
        return np.concatenate([x - d[0] for x in d])

    h = 0.1
    cols = []
    for n in names:
        up, down = dict(truth), dict(truth)
        up[n] += h
        down[n] -= h
        cols.append((readings(up) - readings(down)) / (2.0 * h))
    j = np.column_stack(cols)
    cov = np.linalg.inv(j.T @ j)
    return {n: u * math.sqrt(cov[i, i]) for i, n in enumerate(names)}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--kinematics", choices=["AC", "BC"], required=True)
    ap.add_argument("--poses", choices=["full", "tilt0", "on_axis", "random"], default="full")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--noise", type=float, default=0.5)
    ap.add_argument("--count", type=int, default=1000)
    ap.add_argument("--hidden", default="")
    ap.add_argument("--dt", type=float, default=2.0)
    ap.add_argument("--truth", choices=["default", "zero"], default="default")
    ap.add_argument("--gum-u", type=float, default=None)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    kin = a.kinematics
    setup = dict(SETUP[kin])
    if a.poses == "on_axis":  # the sphere on the C line: its height cannot be told from XOC, YOC
        setup["sphere"] = (setup["c"][0], setup["c"][1], setup["sphere"][2])
    truth = TRUTH[kin]
    if a.truth == "zero":
        truth = {k: 0.0 for k in truth}
    hidden = [h for h in a.hidden.split(",") if h]
    zero = {k: 0.0 for k in truth}
    rng = np.random.default_rng(a.seed)
    tilt = "a" if kin == "AC" else "b"
    text = ["# format: kinemetric-rotary/1", "# machine_id: sim-%s" % kin.lower(),
            "# test_id: %s-%s-%d" % (kin, a.poses, a.seed), "# timestamp: 2026-03-01T10:00:00Z",
            "# kinematics: %s-trunnion" % kin,
            "# %s_axis_mm: %.4f, %.4f" % (tilt, *setup["tilt"]),
            "# c_axis_mm: %.4f, %.4f" % setup["c"],
            "# sphere_mm: %.4f, %.4f, %.4f" % tuple(setup["sphere"]),
            "# instrument: simulated R-test", "# u_reading_um: %g" % a.noise,
            "%s_deg,c_deg,dx_um,dy_um,dz_um,time_s" % tilt]
    first = None
    pose_list = poses(a.poses, rng, a.count)
    for i, (t, c) in enumerate(pose_list):
        time_s = a.dt * i
        d = displacement(kin, setup, truth, zero, hidden, t, c, time_s / 3600.0)
        first = d if first is None else first
        d = d - first  # the sensors are zeroed at the first pose
        if i > 0:
            d = d + rng.normal(0.0, a.noise, 3)
        text.append("%.6f,%.6f,%.5f,%.5f,%.5f,%.1f" % (t, c, d[0], d[1], d[2], time_s))
    with open(a.out, "w", encoding="utf-8") as f:
        f.write("\n".join(text) + "\n")
    out = {"errors": truth, "sphere_mm": list(setup["sphere"]),
           "hidden": {h: HIDDEN.get(h, {}) for h in hidden}}
    if a.gum_u is not None:
        out["u_gum"] = first_order_u(kin, setup, truth, pose_list, a.gum_u)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
