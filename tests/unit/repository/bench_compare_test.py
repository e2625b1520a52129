#!/usr/bin/python3
"""tests/bench/compare.py reads interleaved Google Benchmark runs of two builds: the medians of
each side, the ratio new/ref of the medians and the spread of the rounds' ratios, computed here by
hand for made-up runs; a benchmark of one side only is "new" or "gone"; units are honoured;
aggregates and failed runs are left out; an empty directory is exit 2."""
import json
import os
import subprocess
import sys
import tempfile

COMPARE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench",
                       "compare.py")


def write(out, bench, side, rnd, rows):
    with open(os.path.join(out, "%s.%s.%d.json" % (bench, side, rnd)), "w") as f:
        json.dump({"benchmarks": rows}, f)


def row(name, t, unit="ms", **extra):
    return dict({"name": name, "real_time": t, "time_unit": unit, "run_type": "iteration"},
                **extra)


def main():
    failures = []
    with tempfile.TemporaryDirectory() as out:
        empty = subprocess.run(["/usr/bin/python3", COMPARE, out], capture_output=True)
        if empty.returncode != 2:
            failures.append("an empty directory: exit %d" % empty.returncode)
        # Pair: ref 4, 5, 6 ms; new 2, 2.4, 3.3 ms → medians 5 and 2.4, ratio 0.48; rounds'
        # ratios 0.5, 0.48, 0.55.
        for rnd, (r, n) in enumerate(((4, 2), (5, 2.4), (6, 3.3)), start=1):
            write(out, "dbb_bench", "ref", rnd,
                  [row("Pair", r), row("Gone", 1), row("Pair_mean", 99, run_type="aggregate")])
            write(out, "dbb_bench", "new", rnd,
                  [row("Pair", n * 1000, unit="us"), row("Fresh", 1),
                   row("Broken", 1, error_occurred=True)])
        got = subprocess.run(["/usr/bin/python3", COMPARE, out], capture_output=True, text=True)
        lines = {line.split()[1]: line for line in got.stdout.splitlines()[1:]}
        pair = lines.get("Pair", "")
        for want in ("5 ms", "2.4 ms", "0.48", "0.48 … 0.55 (3 rounds)"):
            if want not in pair:
                failures.append("Pair line lacks %r: %r" % (want, pair))
        if "gone" not in lines.get("Gone", ""):
            failures.append("Gone: %r" % lines.get("Gone"))
        if "new" not in lines.get("Fresh", ""):
            failures.append("Fresh: %r" % lines.get("Fresh"))
        if "Broken" in lines or "Pair_mean" in lines:
            failures.append("aggregates or errors listed: %s" % got.stdout)
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
