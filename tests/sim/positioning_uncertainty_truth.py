#!/usr/bin/python3
"""Independent Monte Carlo ([JCGM 101] §7) of the uncertainty of every ISO 230-2 and VDI/DGQ 3441
figure of a kinemetric-positioning/1 file, written straight from the definitions
(docs/methods.md §15, §16.3) with numpy: in every trial the stated inputs (u_laser_ppm,
u_air_temperature_c, u_air_pressure_pa, u_air_humidity_pct, u_material_temperature_c,
u_expansion_ppm_per_k; standard uncertainties, normal) are drawn once, every raw reading of the
file is corrected with them (the laser's distance scaled by 1 + ε, divided by n of the drawn air
from the Edlén equation, the drawn thermal expansion to 20 °C removed), and the figures are
computed again from the corrected readings: means, standard deviations, reversals, then
the axis figures. Prints {figure: {"u_um", "U_um", "low_um", "high_um"}} as JSON, U = 2u,
[low, high] the probabilistically symmetric 95 % interval. Shares no code with the product;
tests/unit/positioning/positioning_uncertainty_test.cpp compares the two.

  positioning_uncertainty_truth.py FILE [--draws N] [--seed S]"""
import argparse
import json

import numpy as np


def read(path):
    header, rows, columns = {}, [], None
    for line in open(path, encoding="utf-8"):
        line = line.strip()
        if not line:
            continue
        if line.startswith("#"):
            key, _, value = line[1:].partition(":")
            header[key.strip()] = value.strip()
        elif columns is None:
            columns = [c.strip() for c in line.split(",")]
        else:
            rows.append(dict(zip(columns, [c.strip() for c in line.split(",")])))
    return header, rows


def saturation_pa(t):
    """IAPWS-IF97 saturation pressure over water ([NIST refractive index] A-I), t in °C."""
    k = [1.16705214528e3, -7.24213167032e5, -1.70738469401e1, 1.20208247025e4,
         -3.23255503223e6, 1.49151086135e1, -4.82326573616e3, 4.05113405421e5,
         -2.38555575678e-1, 6.50175348448e2]
    T = t + 273.15
    w = T + k[8] / (T - k[9])
    a = w * w + k[0] * w + k[1]
    b = k[2] * w * w + k[3] * w + k[4]
    c = k[5] * w * w + k[6] * w + k[7]
    return 1e6 * (2 * c / (-b + np.sqrt(b * b - 4 * a * c))) ** 4


def edlen(t, p, rh, wavelength_nm):
    """The modified Edlén equation ([NIST refractive index] A-IV), vectorised over draws."""
    s = 1.0 / (wavelength_nm / 1000.0) ** 2
    ns = 1e-8 * (8342.54 + 2406147 / (130 - s) + 15998 / (38.9 - s))
    x = (1 + 1e-8 * (0.601 - 0.00972 * t) * p) / (1 + 0.003661 * t)
    ntp = 1 + p * ns * x / 96095.43
    return ntp - 1e-10 * (292.75 / (t + 273.15)) * (3.7345 - 0.0401 * s) * rh / 100 * saturation_pa(t)


def raw_readings(header, rows):
    """Raw deviations (µm) as an array [run, direction (+, -), target], the targets ascending."""
    targets = sorted({round(float(r["target_mm"]), 6) for r in rows})
    runs = sorted({int(r["run"]) for r in rows})
    x = np.full((len(runs), 2, len(targets)), np.nan)
    for r in rows:
        target = float(r["target_mm"])
        if "measured_mm" in r:
            dev = (float(r["measured_mm"]) - target) * 1000
        else:
            dev = float(r["deviation_um"])
        x[runs.index(int(r["run"])), 0 if r["direction"] == "+" else 1,
          targets.index(round(target, 6))] = dev
    assert not np.isnan(x).any(), "every target in both directions of every run"
    return np.array(targets), x


def figures(x):
    """The figures of corrected readings x[draw, run, direction, target] ([ISO 230-2] clause 2,
    [VDI/DGQ 3441]), each an array over the draws."""
    mean = x.mean(axis=1)                    # [draw, direction, target]
    s = x.std(axis=1, ddof=1)
    up, dn, su, sd = mean[:, 0], mean[:, 1], s[:, 0], s[:, 1]
    B = up - dn
    xm = (up + dn) / 2
    Ri = np.maximum(np.maximum(2 * su + 2 * sd + np.abs(B), 4 * su), 4 * sd)
    span = lambda a: a.max(axis=1) - a.min(axis=1)  # noqa: E731
    both = np.concatenate([up, dn], axis=1)
    hi = np.concatenate([up + 2 * su, dn + 2 * sd], axis=1)
    lo = np.concatenate([up - 2 * su, dn - 2 * sd], axis=1)
    ps = 6 * (su + sd) / 2
    U = np.abs(B)
    return {
        "accuracy_um": hi.max(axis=1) - lo.min(axis=1),
        "accuracy_up_um": (up + 2 * su).max(axis=1) - (up - 2 * su).min(axis=1),
        "accuracy_down_um": (dn + 2 * sd).max(axis=1) - (dn - 2 * sd).min(axis=1),
        "systematic_deviation_um": span(both),
        "systematic_deviation_up_um": span(up),
        "systematic_deviation_down_um": span(dn),
        "mean_deviation_range_um": span(xm),
        "reversal_value_um": np.abs(B).max(axis=1),
        "mean_reversal_value_um": B.mean(axis=1),
        "repeatability_um": Ri.max(axis=1),
        "repeatability_up_um": (4 * su).max(axis=1),
        "repeatability_down_um": (4 * sd).max(axis=1),
        "vdi3441.P_um": (xm + (U + ps) / 2).max(axis=1) - (xm - (U + ps) / 2).min(axis=1),
        "vdi3441.Ps_um": ps.max(axis=1),
        "vdi3441.U_um": U.max(axis=1),
        "vdi3441.Pa_um": span(xm),
    }


def draw_chunk(header, targets, x_raw, rng, count):
    u = lambda key: float(header.get(key, 0.0))  # noqa: E731
    datum = float(header["datum_mm"])
    d = (targets - datum) * 1000.0            # distance from the datum, µm
    eps = rng.normal(0.0, u("u_laser_ppm") * 1e-6, count)
    n = np.ones(count)
    if header["air_compensated"] == "no":
        t = rng.normal(float(header["air_temperature_c"]), u("u_air_temperature_c"), count)
        p = rng.normal(float(header["air_pressure_pa"]), u("u_air_pressure_pa"), count)
        rh = rng.normal(float(header["air_humidity_pct"]), u("u_air_humidity_pct"), count)
        n = edlen(t, p, np.clip(rh, 0, 100), float(header["laser_wavelength_nm"]))
    growth = np.zeros(count)                  # α·(T − 20)·10⁻⁶, per µm of distance
    if "material_temperature_c" in header:
        T = rng.normal(float(header["material_temperature_c"]), u("u_material_temperature_c"), count)
        a = rng.normal(float(header["expansion_ppm_per_k"]), u("u_expansion_ppm_per_k"), count)
        growth = a * (T - 20.0) * 1e-6
    # Every reading: the laser's distance from the datum L = d + x, read as L·(1 + ε), divided
    # by n, the target's distance taken off, the scale's growth removed.
    L = d[None, None, :] + x_raw                                  # [run, direction, target]
    scale = ((1.0 + eps) / n)[:, None, None, None]
    x = L[None] * scale - d - growth[:, None, None, None] * d
    return figures(x)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("file")
    ap.add_argument("--draws", type=int, default=100_000)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    header, rows = read(args.file)
    targets, x_raw = raw_readings(header, rows)
    rng = np.random.default_rng(args.seed)
    chunks = []
    left = args.draws
    while left > 0:
        count = min(left, 10_000)
        chunks.append(draw_chunk(header, targets, x_raw, rng, count))
        left -= count
    out = {}
    for key in chunks[0]:
        y = np.concatenate([c[key] for c in chunks])
        u = float(y.std(ddof=1))
        lo, hi = np.quantile(y, [0.025, 0.975])
        out[key] = {"u_um": u, "U_um": 2 * u, "low_um": float(lo), "high_um": float(hi)}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
