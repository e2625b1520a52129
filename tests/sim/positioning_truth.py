#!/usr/bin/python3
"""Independent evaluation of a kinemetric-positioning/1 file, written straight from the
definitions (docs/methods.md §15: [ISO 230-2] clause 2, [VDI/DGQ 3441], [Birch & Downs 1994] in
the form of [NIST refractive index] A-I, A-II, A-IV). Prints the figures as one JSON object.
Shares no code with the product; tests/unit/positioning compares the two."""
import json
import math
import statistics
import sys


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
    k = [1.16705214528e3, -7.24213167032e5, -1.70738469401e1, 1.20208247025e4,
         -3.23255503223e6, 1.49151086135e1, -4.82326573616e3, 4.05113405421e5,
         -2.38555575678e-1, 6.50175348448e2]
    T = t + 273.15
    w = T + k[8] / (T - k[9])
    a = w * w + k[0] * w + k[1]
    b = k[2] * w * w + k[3] * w + k[4]
    c = k[5] * w * w + k[6] * w + k[7]
    return 1e6 * (2 * c / (-b + math.sqrt(b * b - 4 * a * c))) ** 4


def edlen(t, p, rh, wavelength_nm):
    s = 1.0 / (wavelength_nm / 1000.0) ** 2
    ns = 1e-8 * (8342.54 + 2406147 / (130 - s) + 15998 / (38.9 - s))
    x = (1 + 1e-8 * (0.601 - 0.00972 * t) * p) / (1 + 0.003661 * t)
    ntp = 1 + p * ns * x / 96095.43
    return ntp - 1e-10 * (292.75 / (t + 273.15)) * (3.7345 - 0.0401 * s) * rh / 100 * saturation_pa(t)


def deviations(header, rows):
    datum = float(header["datum_mm"])
    n = 1.0
    if header["air_compensated"] == "no":
        n = edlen(float(header["air_temperature_c"]), float(header["air_pressure_pa"]),
                  float(header["air_humidity_pct"]), float(header["laser_wavelength_nm"]))
    out = {}
    for r in rows:
        target = float(r["target_mm"])
        measured = float(r["measured_mm"]) if "measured_mm" in r else target + float(r["deviation_um"]) / 1000
        measured = datum + (measured - datum) / n
        x = (measured - target) * 1000
        if "material_temperature_c" in header:
            x -= float(header["expansion_ppm_per_k"]) * 1e-6 * (float(header["material_temperature_c"]) - 20) * (target - datum) * 1000
        out.setdefault(round(target, 6), {"+": [], "-": []})[r["direction"]].append(x)
    return out, n


def figures(path):
    header, rows = read(path)
    data, n = deviations(header, rows)
    P = sorted(data)
    up = [statistics.mean(data[p]["+"]) for p in P]
    dn = [statistics.mean(data[p]["-"]) for p in P]
    su = [statistics.stdev(data[p]["+"]) for p in P]
    sd = [statistics.stdev(data[p]["-"]) for p in P]
    B = [u - d for u, d in zip(up, dn)]
    xm = [(u + d) / 2 for u, d in zip(up, dn)]
    Ri = [max(2 * a + 2 * b + abs(c), 4 * a, 4 * b) for a, b, c in zip(su, sd, B)]
    runs = len(set(r["run"] for r in rows))
    f = {
        "reversal_value_um": max(abs(b) for b in B),
        "mean_reversal_value_um": sum(B) / len(B),
        "repeatability_up_um": max(4 * s for s in su),
        "repeatability_down_um": max(4 * s for s in sd),
        "repeatability_um": max(Ri),
        "systematic_deviation_up_um": max(up) - min(up),
        "systematic_deviation_down_um": max(dn) - min(dn),
        "systematic_deviation_um": max(up + dn) - min(up + dn),
        "mean_deviation_range_um": max(xm) - min(xm),
        "accuracy_up_um": max(u + 2 * s for u, s in zip(up, su)) - min(u - 2 * s for u, s in zip(up, su)),
        "accuracy_down_um": max(u + 2 * s for u, s in zip(dn, sd)) - min(u - 2 * s for u, s in zip(dn, sd)),
        "accuracy_um": max([u + 2 * s for u, s in zip(up, su)] + [u + 2 * s for u, s in zip(dn, sd)])
        - min([u - 2 * s for u, s in zip(up, su)] + [u - 2 * s for u, s in zip(dn, sd)]),
        "iso230_2_compliant": runs >= 5 and len(P) >= 5,
        "refractive_index": n,
        "targets": {"target_mm": P, "mean_up_um": up, "mean_down_um": dn, "s_up_um": su,
                    "s_down_um": sd, "reversal_um": B, "mean_bidirectional_um": xm},
    }
    ps = [6 * (a + b) / 2 for a, b in zip(su, sd)]
    U = [abs(b) for b in B]
    f["vdi3441"] = {
        "P_um": max(x + (u + p) / 2 for x, u, p in zip(xm, U, ps)) - min(x - (u + p) / 2 for x, u, p in zip(xm, U, ps)),
        "Ps_um": max(ps), "U_um": max(U), "Pa_um": max(xm) - min(xm)}
    return f


if __name__ == "__main__":
    print(json.dumps(figures(sys.argv[1])))
