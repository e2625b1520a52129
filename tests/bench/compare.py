#!/usr/bin/python3
"""The side-by-side summary of tests/bench/compare.sh: Google Benchmark JSON files of a
reference build and of the working tree, run in interleaved rounds on one machine, give each
benchmark's median time in both, the ratio new/ref of the medians, and the spread of the
per-round ratios (their smallest and largest), so a claim "2.1x faster" is read with its spread.

    compare.py OUT_DIR        (OUT_DIR/<bench>.<ref|new>.<round>.json, written by compare.sh)

A benchmark in only one of the two builds is listed as new or gone. Exit 0; 2 when OUT_DIR holds
no results."""
import glob
import json
import os
import re
import statistics
import sys

NAME = re.compile(r"^(?P<bench>.+)\.(?P<side>ref|new)\.(?P<round>\d+)\.json$")


def times(path):
    """{benchmark name: real time in ns} of one run (aggregates and errors left out)."""
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    scale = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}
    out = {}
    for b in data.get("benchmarks", []):
        if b.get("run_type") == "aggregate" or b.get("error_occurred"):
            continue
        out[b["name"]] = float(b["real_time"]) * scale.get(b.get("time_unit", "ns"), 1.0)
    return out


def collect(out_dir):
    """{(bench, name): {"ref": {round: t}, "new": {round: t}}}."""
    runs = {}
    for path in sorted(glob.glob(os.path.join(out_dir, "*.json"))):
        m = NAME.match(os.path.basename(path))
        if not m:
            continue
        for name, t in times(path).items():
            entry = runs.setdefault((m["bench"], name), {"ref": {}, "new": {}})
            entry[m["side"]][int(m["round"])] = t
    return runs


def human(ns):
    for unit, scale in (("s", 1e9), ("ms", 1e6), ("us", 1e3)):
        if ns >= scale:
            return "%.3g %s" % (ns / scale, unit)
    return "%.3g ns" % ns


def summary(runs):
    lines = ["%-60s %12s %12s %8s  %s" % ("benchmark", "ref", "new", "new/ref",
                                          "spread of the rounds' ratios")]
    for (bench, name), sides in sorted(runs.items()):
        label = (bench + ": " + name)[:60]
        if not sides["ref"] or not sides["new"]:
            lines.append("%-60s %s" % (label, "new" if sides["new"] else "gone"))
            continue
        ref = statistics.median(sides["ref"].values())
        new = statistics.median(sides["new"].values())
        rounds = sorted(set(sides["ref"]) & set(sides["new"]))
        ratios = [sides["new"][r] / sides["ref"][r] for r in rounds if sides["ref"][r] > 0]
        spread = "%.2f … %.2f (%d rounds)" % (min(ratios), max(ratios), len(ratios)) \
            if ratios else "—"
        lines.append("%-60s %12s %12s %8.2f  %s" % (label, human(ref), human(new),
                                                    new / ref if ref > 0 else float("nan"),
                                                    spread))
    return "\n".join(lines)


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    runs = collect(sys.argv[1])
    if not runs:
        print("compare.py: no benchmark results in %s" % sys.argv[1], file=sys.stderr)
        return 2
    print(summary(runs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
