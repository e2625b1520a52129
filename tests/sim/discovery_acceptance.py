#!/usr/bin/python3
"""Acceptance harness of hexapod model-gap discovery (`kinemetric discover --machine`).

For each scenario and seed, tests/sim/hexapod_truth.py simulates the 30 DBB files of the jig
plan with hidden effects (docs/hexapod-effects.md); `kinemetric discover` must name exactly the
injected effects, each step must remove ≥ 80 % of the gap attributable to it (≥ 60 % for the
variants of another functional form), the unexplained rest must be noise (≤ 1.3 σ) and
K_stiff2, the wrong tool's error and the drift rate must come back within 5 % (variants: naming
and shrink only). Prints a table; exit status 1 on any failure.

  /usr/bin/python3 tests/sim/discovery_acceptance.py --bin build/bin [--quick]
      [--scenario NAME]... [--keep DIR]
"""

import argparse
import dataclasses
import json
import math
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SIMULATOR = os.path.join(HERE, "hexapod_truth.py")
MACHINE = os.path.join(REPO, "tests", "fixtures", "pm600-like.json")
PYTHON = "/usr/bin/python3"

NOISE_UM = 0.3
UNEXPLAINED_LIMIT_UM = 1.3 * NOISE_UM
# A step must remove ≥ 80 % (variants: ≥ 60 %) of the gap attributable to it: its gap after is
# at most 0.2 (0.4) × its gap before, both measured above the noise and above what later steps
# explain (attributable_shrink).
SHRINK = 0.2
SHRINK_VARIANT = 0.4
PARAMETER_TOLERANCE = 0.05

GRAVITY = "gravity_deflection:K_stiff2_mm_per_N=1.52e-5"
FRICTION = "joint_friction:torque_Nm=8.88,ramp_mm=2"
TOOL = "tool_length_error:104.255=-62,150=0"
DRIFT = "thermal_drift:rate_um_per_h=20"


@dataclasses.dataclass
class Scenario:
    name: str
    effects: list          # --effect arguments of the simulator
    named: list            # effects discovery must add (and no other)
    parameters: dict       # (effect, parameter) → true value, checked within 5 %
    variants: list = dataclasses.field(default_factory=list)
    seeds: tuple = (1, 2, 3)

    @property
    def is_variant(self):
        return bool(self.variants)


SCENARIOS = [
    Scenario("null", [], [], {}),
    Scenario("gravity", [GRAVITY], ["gravity_deflection"],
             {("gravity_deflection", "K_stiff2_mm_per_N"): 1.52e-5}),
    Scenario("friction", [FRICTION], ["joint_friction"], {}),
    Scenario("tool", [TOOL], ["tool_length_error"],
             {("tool_length_error", "error_um[104.255]"): -62.0}),
    Scenario("drift", [DRIFT], ["thermal_drift"], {("thermal_drift", "rate_um_per_h"): 20.0}),
    Scenario("gravity+friction", [GRAVITY, FRICTION], ["gravity_deflection", "joint_friction"],
             {("gravity_deflection", "K_stiff2_mm_per_N"): 1.52e-5}),
    Scenario("gravity_alt_mass", [GRAVITY], ["gravity_deflection"], {},
             ["gravity_alt_mass"], (1,)),
    Scenario("friction_exponential", [FRICTION], ["joint_friction"], {},
             ["friction_exponential"], (1,)),
    Scenario("drift_step", [DRIFT], ["thermal_drift"], {}, ["drift_step"], (1,)),
]
QUICK = ("null", "gravity", "friction")


@dataclasses.dataclass
class Outcome:
    scenario: str
    seed: int
    sim_s: float = 0.0
    discover_s: float = 0.0
    added: list = dataclasses.field(default_factory=list)
    shrinks: list = dataclasses.field(default_factory=list)  # after / before per step
    explained: list = dataclasses.field(default_factory=list)  # attributable_shrink per step
    unexplained_um: float = float("nan")
    verdict: str = ""
    fitted: list = dataclasses.field(default_factory=list)   # "name=value (truth)"
    failures: list = dataclasses.field(default_factory=list)


def simulate(scenario, seed, out):
    cmd = [PYTHON, SIMULATOR, "--out", out, "--seed", str(seed), "--noise-um", str(NOISE_UM)]
    for e in scenario.effects:
        cmd += ["--effect", e]
    for v in scenario.variants:
        cmd += ["--variant", v]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return sorted(os.path.join(out, n) for n in os.listdir(out) if n.endswith(".dbb"))


# The quick (CI) form uses every third sample of each test (240 per turn): the same physics at a
# third of the cost, so that it also runs under the sanitizers.
DISCOVER_SAMPLES = 0


def discover(kinemetric, files, timeout_s):
    """Runs discovery; returns (JSON object or None, error text)."""
    cmd = [kinemetric, "discover", "--machine", MACHINE, "--json",
           "--samples", str(DISCOVER_SAMPLES)] + files
    try:
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        return None, "discover took longer than %d s" % timeout_s
    except OSError as e:
        return None, "cannot run %s: %s" % (kinemetric, e)
    if run.returncode != 0:
        return None, "discover exit status %d: %s" % (run.returncode,
                                                      run.stderr.strip()[-400:])
    try:
        return json.loads(run.stdout), ""
    except json.JSONDecodeError as e:
        return None, "discover printed no JSON (%s): %s" % (e, run.stdout[:200])


def model_parameter(result, effect, name):
    for entry in result.get("final_model", []):
        if entry.get("effect") == effect:
            return entry.get("parameters", {}).get(name)
    return None


def attributable_shrink(gaps, k):
    """Share of the gap attributable to step k that the step removes.

    The gap before step k holds its own effect, the effects later steps add and the noise;
    a step cannot remove the last two, so they form the floor both gaps are measured above:
    floor² = σ² + (after_k² − after_last²), σ the injected noise. With one step this is the
    shrink of the gap above the noise: 1 − √(after² − σ²)/√(before² − σ²)."""
    before, after = gaps[k]
    floor2 = NOISE_UM ** 2 + max(after ** 2 - gaps[-1][1] ** 2, 0.0)
    excess_before = max(before ** 2 - floor2, 0.0) ** 0.5
    excess_after = max(after ** 2 - floor2, 0.0) ** 0.5
    if excess_before == 0.0:
        return float("nan")  # nothing above the floor: the step had nothing to explain
    return 1.0 - excess_after / excess_before


def check(scenario, result, outcome):
    """Appends to outcome.failures every acceptance rule the discovery result breaks."""
    fail = outcome.failures.append
    steps = result.get("steps", [])
    outcome.added = [s.get("added_effect", "?") for s in steps]
    outcome.verdict = str(result.get("verdict", ""))
    outcome.unexplained_um = float(result.get("unexplained_rms_um", float("nan")))
    for effect in scenario.named:
        if effect not in outcome.added:
            fail("%s not named" % effect)
    for effect in outcome.added:
        if effect not in scenario.named:
            fail("%s added but not injected" % effect)
    limit = SHRINK_VARIANT if scenario.is_variant else SHRINK
    gaps = [(st.get("gap_rms_before_um"), st.get("gap_rms_after_um")) for st in steps]
    if not all(isinstance(v, (int, float)) for pair in gaps for v in pair):
        fail("steps without gap_rms_before_um / gap_rms_after_um")
        gaps = []
    for k, (before, after) in enumerate(gaps):
        name = steps[k].get("added_effect")
        outcome.shrinks.append(after / before if before > 0 else float("nan"))
        shrink = attributable_shrink(gaps, k)
        outcome.explained.append(shrink)
        if math.isnan(shrink):
            fail("step %s: gap %.3f → %.3f µm; nothing above the noise was left for it"
                 % (name, before, after))
        elif shrink < 1.0 - limit:
            fail("step %s: gap %.3f → %.3f µm; it removes %.0f %% of the gap attributable to it "
                 "(< %.0f %%)" % (name, before, after, 100 * shrink, 100 * (1 - limit)))
        if not isinstance(steps[k].get("evidence", {}).get("sentence"), str):
            fail("step %s: no evidence sentence" % name)
    if scenario.is_variant:
        return
    if not outcome.unexplained_um <= UNEXPLAINED_LIMIT_UM:
        fail("unexplained %.3f µm > %.2f µm" % (outcome.unexplained_um, UNEXPLAINED_LIMIT_UM))
    for (effect, name), truth in scenario.parameters.items():
        value = model_parameter(result, effect, name)
        if not isinstance(value, (int, float)):
            fail("%s %s not in final_model" % (effect, name))
            continue
        outcome.fitted.append("%s=%.4g (%.4g)" % (name, value, truth))
        if abs(value - truth) > PARAMETER_TOLERANCE * abs(truth):
            fail("%s = %.4g, truth %.4g (off %.1f %% > 5 %%)"
                 % (name, value, truth, 100 * abs(value / truth - 1)))


def run_one(scenario, seed, kinemetric, timeout_s, keep):
    outcome = Outcome(scenario.name, seed)
    with tempfile.TemporaryDirectory(prefix="km-discovery-") as tmp:
        out = os.path.join(keep, "%s_seed%d" % (scenario.name, seed)) if keep else tmp
        started = time.monotonic()
        try:
            files = simulate(scenario, seed, out)
        except subprocess.CalledProcessError as e:
            outcome.failures.append("simulator failed (status %d)" % e.returncode)
            return outcome
        outcome.sim_s = time.monotonic() - started
        started = time.monotonic()
        result, error = discover(kinemetric, files, timeout_s)
        outcome.discover_s = time.monotonic() - started
        if result is None:
            outcome.failures.append(error)
        else:
            check(scenario, result, outcome)
    return outcome


def print_table(outcomes):
    head = ("scenario", "seed", "sim s", "disc s", "added", "after/before", "removed",
            "unexpl µm",
            "verdict", "fitted (truth)", "result")
    rows = [head]
    for o in outcomes:
        rows.append((o.scenario, str(o.seed), "%.1f" % o.sim_s, "%.1f" % o.discover_s,
                     ",".join(o.added) or "-", ",".join("%.2f" % r for r in o.shrinks) or "-",
                     ",".join("%.0f%%" % (100 * r) for r in o.explained) or "-",
                     "%.3f" % o.unexplained_um, o.verdict or "-", "; ".join(o.fitted) or "-",
                     "FAIL" if o.failures else "ok"))
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
    for o in outcomes:
        for f in o.failures:
            print("FAIL %s seed %d: %s" % (o.scenario, o.seed, f))


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bin", required=True, help="directory with the kinemetric program")
    p.add_argument("--quick", action="store_true",
                   help="only %s with seed 1 (the CI form)" % ", ".join(QUICK))
    p.add_argument("--scenario", action="append", default=[],
                   choices=[s.name for s in SCENARIOS])
    p.add_argument("--timeout-s", type=int, default=900, help="per discover run")
    p.add_argument("--keep", help="keep the simulated files under this directory")
    return p.parse_args(argv)


def main(argv=None):
    global DISCOVER_SAMPLES
    args = parse_args(argv)
    if args.quick:
        DISCOVER_SAMPLES = 240
    kinemetric = os.path.join(args.bin, "kinemetric")
    if not os.access(kinemetric, os.X_OK):
        print("discovery_acceptance: %s is not an executable" % kinemetric, file=sys.stderr)
        return 1
    chosen = [s for s in SCENARIOS
              if (not args.scenario or s.name in args.scenario)
              and (not args.quick or s.name in QUICK)]
    outcomes = []
    for scenario in chosen:
        for seed in (scenario.seeds[:1] if args.quick else scenario.seeds):
            outcomes.append(run_one(scenario, seed, kinemetric, args.timeout_s, args.keep))
            o = outcomes[-1]
            print("%s seed %d: %s" % (o.scenario, o.seed, "FAIL" if o.failures else "ok"),
                  flush=True)
    print()
    print_table(outcomes)
    failed = sum(1 for o in outcomes if o.failures)
    print("\n%d of %d runs passed" % (len(outcomes) - failed, len(outcomes)))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
