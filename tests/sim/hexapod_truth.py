#!/usr/bin/python3
"""Independent truth simulator of DBB circular tests on a hexapod (Stewart platform).

Writes the 30 `kinemetric-dbb/1` files of the jig plan (15 fixed-ball positions x CCW and CW)
that a machine with hidden physical effects would produce, and `truth.json` with what was
hidden. Its physics is written from the source documents alone: [PM-600 report] ch. 1
(kinematics, eqs. 1.1-1.5), ch. 3 (statics Γ eq. 3.4, gravity eqs. 3.5-3.8, friction eqs.
3.9-3.12, table 3.2), ch. 4 (strut compliance eqs. 4.1-4.5) and the [Joint patent] (the
friction change after a reversal, figs. 8 and 10-12, claims 3-4). It shares no code with the
C++ analysis it judges (tests/sim/discovery_acceptance.py).

  /usr/bin/python3 tests/sim/hexapod_truth.py --out DIR [--seed 1] [--noise-um 0.3]
      [--noise-model white|ar1] [--samples 720] [--effect NAME[:key=value,...]]...
      [--variant NAME]... [--platform-joint-error-mm E] [--arc-deg A] [--lead-mm L]
      [--temperature] [--machine M.json]

Effects (the product's names) and their parameters:
  gravity_deflection:K_stiff2_mm_per_N=V[,K_stiff1_mm_per_N=V,platform_mass_kg=M,
                     platform_cog_mm=X/Y/Z]
  joint_friction:torque_Nm=T0,torque_per_N_m=T1[,ramp_mm=λ]       (t0, t1 of eq. 3.12)
  tool_length_error:TOOL_MM=ERR_UM[,...]            (real tool − programmed tool, µm)
  thermal_drift:rate_um_per_h=V[,strain_ppm_per_h=S]
  servo_lag:lag_coefficient_ms2=C
Variants (other readings of the sources): friction_literal, gravity_weight_adds.

Units and the conventions where the sources leave a choice: hexapod_physics.py.
"""

import argparse
import dataclasses
import datetime
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hexapod_physics import (  # noqa: E402 (beside this file)
    REPO, DEFAULT_MACHINE, EFFECTS, VARIANTS, NOISE_MODELS, AR1_RHO, AR1_SHARE, Geometry,
    Machine, load_machine, perturbed_geometry, rotation_derivatives, platform_vectors,
    strut_lengths, forward_kinematics, strut_state, gravity_model,
    gravity_deflection, ramp_states, joint_friction, servo_lag, thermal_drift, LEVEL_Z_MM,
    TOOLS_MM, FEED_MM_MIN, START_TIME, DbbSpec, jig_plan, CommandedPath, commanded_path,
    joint_travel)

# ---------------------------------------------------------------------------------------------
# Effect parameters


def parse_effect(text):
    """`NAME[:key=value,...]` → (name, {key: value}); platform_cog_mm=X/Y/Z is a vector."""
    name, _, rest = text.partition(":")
    name = name.strip()
    if name not in EFFECTS:
        raise ValueError("unknown effect '%s' (known: %s)" % (name, ", ".join(EFFECTS)))
    params = {}
    for item in filter(None, (p.strip() for p in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq:
            raise ValueError("effect '%s': '%s' is not key=value" % (name, item))
        try:
            if "/" in value:
                parsed = [float(v) for v in value.split("/")]
                if len(parsed) != 3:
                    raise ValueError
            else:
                parsed = float(value)
        except ValueError:
            raise ValueError("effect '%s': '%s' is not a number (or X/Y/Z)" % (name, item))
        params[key.strip()] = parsed
    return name, params


def tool_key(tool):
    return "error_um[%g]" % tool


OPTIONAL = {"gravity_deflection": ("K_stiff1_mm_per_N", "platform_mass_kg", "platform_cog_mm")}


def resolve_effects(specs, machine, tools=TOOLS_MM):
    """Every effect with all its parameters, defaults from the machine file."""
    fr = machine.friction
    defaults = {
        "gravity_deflection": {"K_stiff2_mm_per_N": machine.gravity["compliance_other_mm_per_N"]},
        "joint_friction": {"torque_Nm": fr.get("base_joint_torque_Nm", 0.0),
                           "torque_per_N_m": fr.get("base_joint_torque_per_N_m", 0.0),
                           "ramp_mm": 0.0},
        "tool_length_error": {tool_key(t): 0.0 for t in tools},
        "thermal_drift": {"rate_um_per_h": 0.0, "strain_ppm_per_h": 0.0},
        "servo_lag": {"lag_coefficient_ms2": 1000.0},
    }
    aliases = {"K_stiff2": "K_stiff2_mm_per_N", "K_stiff1": "K_stiff1_mm_per_N",
               "torque": "torque_Nm", "t0": "torque_Nm", "t1": "torque_per_N_m",
               "ramp": "ramp_mm", "rate": "rate_um_per_h", "strain": "strain_ppm_per_h",
               "lag": "lag_coefficient_ms2", "platform_mass": "platform_mass_kg",
               "platform_cog": "platform_cog_mm"}
    effects = {}
    for name, given in specs:
        params = dict(defaults[name])
        for key, value in given.items():
            key = aliases.get(key, key)
            if name == "tool_length_error" and not key.startswith("error_um["):
                key = tool_key(float(key))
            if key not in params and key not in OPTIONAL.get(name, ()):
                known = list(params) + list(OPTIONAL.get(name, ()))
                raise ValueError("effect '%s' has no parameter '%s' (known: %s)"
                                 % (name, key, ", ".join(known)))
            if isinstance(value, list) != (key == "platform_cog_mm"):
                raise ValueError("effect '%s': %s takes %s" % (
                    name, key, "X/Y/Z" if key == "platform_cog_mm" else "one number"))
            params[key] = value
        if name == "thermal_drift" and not given:
            params["rate_um_per_h"] = 20.0
        effects[name] = params
    if "joint_friction" in effects and not 0.0 <= effects["joint_friction"]["ramp_mm"] <= 50:
        raise ValueError("joint_friction: ramp_mm must be within 0–50 mm")
    return effects


# ---------------------------------------------------------------------------------------------
# Simulation


@dataclasses.dataclass
class Session:
    machine: Machine
    truth: Geometry
    effects: dict        # name → parameters
    variants: tuple
    noise_um: float
    samples: int
    rng: np.random.Generator
    noise_model: str = "white"
    arc_deg: float = 360.0
    lead_mm: float = 0.0


def effect_deflection(session, s, path, spec, only=None):
    """Σ Δs_j of the effects (N, 6), mm, at the strut state s of the true machine (`only`: that
    effect alone). One physical machine: the compliance and masses of gravity_deflection also
    serve joint_friction; without gravity_deflection they are the machine file's."""
    eff, var = session.effects, session.variants
    gm = gravity_model(session.machine, eff.get("gravity_deflection"),
                       "gravity_weight_adds" in var)
    ds = np.zeros(s.L.shape)
    use = (lambda name: name in eff and (only is None or only == name))
    if use("gravity_deflection"):
        ds += gravity_deflection(s, gm, spec.tool)
    if use("joint_friction"):
        ds += joint_friction(s, gm, spec.tool, eff["joint_friction"], joint_travel(path),
                             "friction_literal" in var, path.closed, path.friction_states)
    if use("thermal_drift"):
        ds += thermal_drift(s, path, eff["thermal_drift"])
    if use("servo_lag"):
        ds += servo_lag(s, path, session.truth, eff["servo_lag"]["lag_coefficient_ms2"])
    return ds


def tool_error_mm(session, tool):
    params = session.effects.get("tool_length_error", {})
    return params.get(tool_key(tool), 0.0) / 1000.0


def path_of(session, spec):
    return commanded_path(spec, session.samples, session.arc_deg, session.lead_mm)


def simulate_dbb(session, spec, details=False, path=None):
    """The bar readings of one test: (path, dr_um without noise[, details for the sizes])."""
    model, truth = session.machine.model, session.truth
    path = path_of(session, spec) if path is None else path
    commanded = strut_lengths(path.x, path.ang, model, spec.tool) - model.offsets  # controller
    s = strut_state(path.x, path.ang, truth, spec.tool)   # the true machine at the command
    d = commanded + truth.offsets + effect_deflection(session, s, path, spec)
    tool = spec.tool + tool_error_mm(session, spec.tool)
    tip, ang = forward_kinematics(d, path.x, path.ang, truth, tool)
    bar = np.linalg.norm(tip - spec.centre, axis=-1)      # fixed ball F = c
    dr = 1000.0 * (bar - spec.bar)
    if not details:
        return path, dr
    return path, dr, (s, tip, ang, tool)


def bar_sensitivity(tip, ang, geom, tool, centre):
    """∂(bar length)/∂s_j (N, 6) at the pose (tip, ang) of geometry geom: δq = J⁻¹ δs with the
    FK Jacobian J (eq. 1.5), δr = n·δX, n the unit bar vector."""
    s = strut_state(tip, ang, geom, tool)
    v = platform_vectors(geom, tool)
    jac = np.empty(s.L.shape + (6,))
    jac[..., :3] = s.u
    for k, dr in enumerate(rotation_derivatives(ang)):
        jac[..., 3 + k] = np.einsum("nja,nab,jb->nj", s.u, dr, v)
    n = tip - centre
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    rhs = np.concatenate([n, np.zeros_like(n)], axis=-1)
    return np.linalg.solve(np.swapaxes(jac, -1, -2), rhs[..., None])[..., 0], s, \
        np.einsum("nab,b->na", s.R, [0.0, 0.0, 1.0])


def effect_sizes(session, records):
    """Each hidden effect's share of the bar readings (linearised, noise-free): its RMS over the
    plan and its RMS after the 24 kinematic parameters (base joints, strut offsets) absorb what
    they can, µm. The second is the gap a calibrated model leaves for the effect."""
    rows = {name: [] for name in list(session.effects) + ["platform_joint_error"]}
    basis = []
    dp = session.truth.platform - session.machine.model.platform
    for spec, path, _, (s, tip, ang, tool) in records:
        sens, s_tip, axis = bar_sensitivity(tip, ang, session.truth, tool, spec.centre)
        # kinematic columns: strut offsets (Δs_j = o_j) and base joints (Δs_j = −l_j·δQ_j)
        cols = [sens[:, j] for j in range(6)]
        for j in range(6):
            for k in range(3):
                cols.append(-sens[:, j] * s_tip.u[:, j, k])
        basis.append(np.stack(cols, axis=1))
        for name in session.effects:
            if name == "tool_length_error":
                n = (tip - spec.centre) / np.linalg.norm(tip - spec.centre, axis=-1)[:, None]
                err = tool_error_mm(session, spec.tool)
                rows[name].append(-1000.0 * err * np.sum(n * axis, axis=-1))
            else:
                ds = effect_deflection(session, s, path, spec, only=name)
                rows[name].append(1000.0 * np.sum(sens * ds, axis=1))
        if np.any(dp != 0.0):
            ds = -np.einsum("nja,nab,jb->nj", s.u, s.R, dp)
            rows["platform_joint_error"].append(1000.0 * np.sum(sens * ds, axis=1))
    a = np.concatenate(basis)
    q, _ = np.linalg.qr(a / np.linalg.norm(a, axis=0))
    sizes = {}
    for name, parts in rows.items():
        if not parts:
            continue
        y = np.concatenate(parts)
        rest = y - q @ (q.T @ y)
        sizes[name] = {"rms_um": float(np.sqrt(np.mean(y ** 2))),
                       "rms_after_kinematics_um": float(np.sqrt(np.mean(rest ** 2)))}
    return sizes


def noise(session, n):
    """One test's measurement noise (n,), µm."""
    sigma, rng = session.noise_um, session.rng
    if sigma <= 0.0:
        return np.zeros(n)
    if session.noise_model == "white":
        return rng.normal(0.0, sigma, size=n)
    w = rng.normal(0.0, math.sqrt(1.0 - AR1_RHO ** 2), size=n)
    ar = np.empty(n)
    ar[0] = rng.normal()
    for i in range(1, n):
        ar[i] = AR1_RHO * ar[i - 1] + w[i]
    wander = np.cumsum(rng.normal(size=n))
    wander -= wander.mean()
    rms = lambda v: math.sqrt(float(np.mean(v ** 2))) or 1.0  # noqa: E731
    total = math.sqrt(AR1_SHARE) * ar / rms(ar) + math.sqrt(1.0 - AR1_SHARE) * wander / rms(wander)
    return sigma * total / rms(total)


def gravity_sign_check(machine, effects, variants):
    """With gravity only, the tool tip's displacement (mm) at the untilted jig centre of level 1
    (model geometry): it must sag, −z."""
    session = Session(machine, machine.model,
                      {"gravity_deflection": effects["gravity_deflection"]}, tuple(variants),
                      0.0, 1, np.random.default_rng(0))
    spec = DbbSpec("sign", "ccw", np.array([0.0, 0.0, LEVEL_Z_MM[1]]), 0.0, 0.0, 0.0,
                   (0.0, 0.0, 0.0), TOOLS_MM[0], 0.0)
    zero = np.zeros((1, 3))
    path = CommandedPath(np.zeros(1), spec.centre[None, :], zero, spec.tool, np.zeros(1), zero,
                         zero, 1.0, True)
    s = strut_state(path.x, path.ang, machine.model, spec.tool)
    d = s.L + effect_deflection(session, s, path, spec)
    tip, _ = forward_kinematics(d, path.x, path.ang, machine.model, spec.tool)
    return (tip - path.x)[0]


def friction_lag(machine, params, variants=(), direction="ccw", z_mm=-1215.0):
    """Tip displacement under joint friction alone on the untilted R 150 circle about (0, 0, z)
    (default: the report's condition C of table 3.3; model geometry, no noise): mean component
    along the motion (negative = the tool lags its command) and mean radial component, µm."""
    session = Session(machine, machine.model, {"joint_friction": params}, tuple(variants),
                      0.0, 720, np.random.default_rng(0))
    spec = DbbSpec("lag", direction, np.array([0.0, 0.0, z_mm]), 150.0, 150.0, 0.0, (0.0, 0.0, 0.0),
                   TOOLS_MM[0], 0.0)
    path = path_of(session, spec)
    s = strut_state(path.x, path.ang, machine.model, spec.tool)
    d = s.L + effect_deflection(session, s, path, spec)
    tip, _ = forward_kinematics(d, path.x, path.ang, machine.model, spec.tool)
    dx = 1000.0 * (tip - path.x)
    along = np.sum(dx * path.velocity, axis=-1) / np.linalg.norm(path.velocity, axis=-1)
    radial = np.sum(dx * (path.x - spec.centre), axis=-1) / spec.radius
    return float(np.mean(along)), float(np.mean(radial))


def iso_time(start, seconds):
    t0 = datetime.datetime.strptime(start, "%Y-%m-%dT%H:%M:%SZ")
    return (t0 + datetime.timedelta(seconds=seconds)).strftime("%Y-%m-%dT%H:%M:%SZ")


def num(v):
    """Shortest text that reads back as the same number, integers without '.0'."""
    v = float(v) + 0.0
    return str(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)


def triple(v):
    return ", ".join(num(c) for c in v)


def dbb_text(machine_id, spec, theta, dr_um, start_time, temperature=None, arc_deg=360.0):
    lines = ["# format: kinemetric-dbb/1",
             "# machine_id: " + machine_id,
             "# test_id: " + spec.test_id,
             "# direction: " + spec.direction,
             "# plane: XY",
             "# bar_length_mm: " + num(spec.bar),
             "# radius_mm: " + num(spec.radius),
             "# centre_mm: " + triple(spec.centre),
             "# z_offset_mm: " + num(spec.z_offset),
             "# feed_mm_min: " + num(FEED_MM_MIN),
             "# tilt_deg: " + triple(spec.tilt_deg),
             "# tool_length_mm: " + num(spec.tool),
             "# fixed_ball_mm: " + triple(spec.centre),
             "# timestamp: " + iso_time(start_time, spec.start_s)]
    if arc_deg < 360.0:
        lines.append("# arc_deg: " + num(arc_deg))
    if temperature is not None:
        lines.append("# temperature_c: %.3f" % temperature)
    lines.append("angle_deg,dr_um")
    lines += ["%.6f,%.6f" % (a, r) for a, r in zip(np.degrees(theta) + 0.0, dr_um + 0.0)]
    return "\n".join(lines) + "\n"


def file_name(spec):
    return "%s_%s.dbb" % (spec.test_id, spec.direction)


def plan_paths(session, plan):
    """The commanded paths of the plan; with a friction ramp, the friction states of all tests
    with the same number of samples computed side by side (one loop over the samples)."""
    paths = [path_of(session, spec) for spec in plan]
    friction = session.effects.get("joint_friction")
    if friction is not None and friction["ramp_mm"] > 0.0:
        groups = {}
        for k, path in enumerate(paths):
            groups.setdefault((path.x.shape[0], path.closed), []).append(k)
        for (_, closed), ks in groups.items():
            travel = np.stack([joint_travel(paths[k]) for k in ks])
            u = np.stack([strut_state(paths[k].x, paths[k].ang, session.truth, plan[k].tool).u
                          for k in ks])
            states = ramp_states(travel, u, friction["ramp_mm"],
                                 "friction_literal" in session.variants, closed)
            for i, k in enumerate(ks):
                paths[k].friction_states = states[i]
    return paths


def simulate_session(session, details=False):
    """All tests of the plan in memory: list of (spec, θ, dr_um with noise); with `details`
    also the records effect_sizes needs."""
    plan = jig_plan()
    results, records = [], []
    for spec, path in zip(plan, plan_paths(session, plan)):
        path, dr, extra = simulate_dbb(session, spec, details=True, path=path)
        results.append((spec, path.theta, dr + noise(session, dr.size)))
        records.append((spec, path, dr, extra))
    return (results, records) if details else results


def make_session(machine, seed, noise_um, samples, perturb_base_mm, perturb_strut_mm, effects,
                 variants, platform_mm=0.0, noise_model="white", arc_deg=360.0, lead_mm=0.0):
    rng = np.random.default_rng(seed)
    truth = perturbed_geometry(machine.model, rng, perturb_base_mm, perturb_strut_mm, platform_mm)
    for v in variants:
        if v not in VARIANTS:
            raise ValueError("unknown variant '%s' (known: %s)" % (v, ", ".join(VARIANTS)))
        if not any(e in effects for e in VARIANTS[v]):
            raise ValueError("variant '%s' changes %s, which is not among the effects"
                             % (v, " or ".join(VARIANTS[v])))
    if noise_model not in NOISE_MODELS:
        raise ValueError("unknown noise model '%s'" % noise_model)
    if not 180.0 <= arc_deg <= 360.0:
        raise ValueError("--arc-deg must be within 180–360")
    if lead_mm < 0.0:
        raise ValueError("--lead-mm must not be negative")
    return Session(machine, truth, effects, tuple(variants), noise_um, samples, rng,
                   noise_model, arc_deg, lead_mm)


CONVENTIONS = [
    "l_j from base joint Q_j to platform joint P_j (eq. 1.2); B_j, B_P from the tool tip",
    "axial gravity force F = Γ⁻¹([N_g; M_g]) ∓ m_T g·l_j, tension positive, deflects Δs = K_j F "
    "(eq. 4.2 with the sign that stretches a strut in tension); − as eq. 3.5 prints it, + with "
    "gravity_weight_adds",
    "K_j = K_stiff1 (L_j − l2)/l3 + K_stiff2 (eq. 4.3), L_j joint to joint",
    "friction force at P_j: size (t0 + t1|F_j|)/L_j[m] opposing the platform joint's commanded "
    "velocity normal to the strut (friction_literal: the full velocity); strut loads by eq. 3.9",
    "friction ramp: state vector on the unit disk, r ← P(r + 2δ/λ); reversal over a travel λ",
    "thermal drift: rate·t + strain·1e-6·L_j·t, t in h from the first test",
]


def truth_json(args, session, sign_dz_um, lag, sizes, files, elapsed_s):
    t = session.truth
    return {
        "format": "kinemetric-sim-truth/1",
        "simulator": "tests/sim/hexapod_truth.py",
        "machine_id": session.machine.machine_id,
        "machine_file": os.path.relpath(os.path.abspath(args.machine), REPO),
        "seed": args.seed,
        "noise_um": session.noise_um,
        "noise_model": session.noise_model,
        "samples_per_turn": session.samples,
        "arc_deg": session.arc_deg,
        "lead_mm": session.lead_mm,
        "perturbation": {"base_mm": args.perturb_base_mm, "strut_mm": args.perturb_strut_mm,
                         "platform_joint_mm": args.platform_joint_error_mm},
        "true_geometry": {"base_joints_mm": t.base.tolist(),
                          "platform_joints_mm": t.platform.tolist(),
                          "strut_offset_mm": t.offsets.tolist()},
        "effects": [{"effect": name, "parameters": params}
                    for name, params in session.effects.items()],
        "variants": list(session.variants),
        "effect_size_um": sizes,
        "gravity_sign_check_tip_dz_um": sign_dz_um,
        "friction_lag_um": lag,
        "conventions": CONVENTIONS,
        "simulation_s": elapsed_s,
        "files": files,
    }


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="output directory (created)")
    p.add_argument("--machine", default=DEFAULT_MACHINE, help="machine file (the model)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--noise-um", type=float, default=0.3)
    p.add_argument("--noise-model", default="white", choices=NOISE_MODELS)
    p.add_argument("--samples", type=int, default=720, help="samples per turn")
    p.add_argument("--perturb-base-mm", type=float, default=0.3)
    p.add_argument("--perturb-strut-mm", type=float, default=0.1)
    p.add_argument("--platform-joint-error-mm", type=float, default=0.0,
                   help="move every platform joint coordinate by ±E (outside the 24-parameter "
                        "kinematic model)")
    p.add_argument("--arc-deg", type=float, default=360.0, help="partial arcs (180–360)")
    p.add_argument("--lead-mm", type=float, default=0.0, help="lead-in and lead-out arcs")
    p.add_argument("--effect", action="append", default=[], help="NAME[:key=value,...]")
    p.add_argument("--variant", action="append", default=[], choices=sorted(VARIANTS))
    p.add_argument("--temperature", action="store_true",
                   help="write temperature_c (rising by --heating-k-per-h from 20 °C)")
    p.add_argument("--heating-k-per-h", type=float, default=1.0)
    p.add_argument("--start-time", default=START_TIME)
    p.add_argument("--no-sizes", action="store_true",
                   help="skip the effect sizes of truth.json (faster)")
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(argv)
    started = time.monotonic()
    machine = load_machine(args.machine)
    try:
        effects = resolve_effects([parse_effect(e) for e in args.effect], machine)
        session = make_session(machine, args.seed, args.noise_um, args.samples,
                               args.perturb_base_mm, args.perturb_strut_mm, effects,
                               args.variant, args.platform_joint_error_mm, args.noise_model,
                               args.arc_deg, args.lead_mm)
    except ValueError as e:
        print("hexapod_truth: " + str(e), file=sys.stderr)
        return 2
    sign_dz_um = None
    if "gravity_deflection" in effects:
        sign_dz_um = 1000.0 * gravity_sign_check(machine, effects, args.variant)[2]
        if not sign_dz_um < 0.0:
            print("hexapod_truth: gravity sign check failed: the untilted tool tip moves %+.3f µm "
                  "in z (it must sag, −z); no files written" % sign_dz_um, file=sys.stderr)
            return 1
    lag = None
    if "joint_friction" in effects:
        along, radial = friction_lag(machine, effects["joint_friction"], args.variant)
        lag = {"z_mm": -1215.0, "along_path_um": along, "radial_um": radial}
    results, records = simulate_session(session, details=True)
    sizes = {} if args.no_sizes else effect_sizes(session, records)
    os.makedirs(args.out, exist_ok=True)
    files = []
    for spec, theta, dr in results:
        temperature = None
        if args.temperature:
            temperature = 20.0 + args.heating_k_per_h * spec.start_s / 3600.0
        with open(os.path.join(args.out, file_name(spec)), "w", encoding="utf-8") as f:
            f.write(dbb_text(machine.machine_id, spec, theta, dr, args.start_time, temperature,
                             session.arc_deg))
        files.append(file_name(spec))
    elapsed = time.monotonic() - started
    with open(os.path.join(args.out, "truth.json"), "w", encoding="utf-8") as f:
        json.dump(truth_json(args, session, sign_dz_um, lag, sizes, files, elapsed), f, indent=2)
        f.write("\n")
    print("hexapod_truth: %d files in %s (%.1f s)" % (len(files), args.out, elapsed))
    return 0


if __name__ == "__main__":
    sys.exit(main())
