#!/usr/bin/python3
"""Independent truth simulator of DBB circular tests on a hexapod (Stewart platform).

Writes the 30 `kinemetric-dbb/1` files of the jig plan (15 fixed-ball positions x CCW and CW)
that a machine with hidden physical effects would produce, and `truth.json` with what was
hidden. It is written from docs/hexapod-effects.md alone and shares no code with the C++
analysis it is used to judge (tests/sim/discovery_acceptance.py).

  /usr/bin/python3 tests/sim/hexapod_truth.py --out DIR [--seed 1] [--noise-um 0.3]
      [--effect NAME[:key=value,...]]... [--variant NAME]... [--temperature]

Effects (docs/hexapod-effects.md): gravity_deflection[:K_stiff2_mm_per_N=V],
joint_friction[:torque_Nm=V,ramp_mm=V,torque_per_N_m=V], tool_length_error:TOOL_MM=ERR_UM[,...],
thermal_drift[:rate_um_per_h=V], servo_lag[:lag_coefficient_ms2=V].
Variants with a different functional form (robustness checks): gravity_alt_mass,
friction_exponential, drift_step.

Units: lengths mm, forces N, torques N·m, angles degrees in files and radians inside.
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

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEFAULT_MACHINE = os.path.join(REPO, "tests", "fixtures", "pm600-like.json")

EFFECTS = ("gravity_deflection", "joint_friction", "tool_length_error", "thermal_drift",
           "servo_lag")
VARIANTS = {"gravity_alt_mass": "gravity_deflection",
            "friction_exponential": "joint_friction",
            "drift_step": "thermal_drift"}

FK_TOLERANCE_MM = 1e-12

# ---------------------------------------------------------------------------------------------
# Machine geometry


@dataclasses.dataclass
class Geometry:
    """Joint positions of one hexapod: base joints Q_j (machine frame), platform joints p_j
    (platform frame, origin at the spindle nose), strut offsets o_j."""
    base: np.ndarray      # (6, 3) mm
    platform: np.ndarray  # (6, 3) mm
    offsets: np.ndarray   # (6,) mm


@dataclasses.dataclass
class Machine:
    machine_id: str
    model: Geometry  # what the controller believes (the machine file)
    gravity: dict
    friction: dict


def load_machine(path):
    with open(path, encoding="utf-8") as f:
        m = json.load(f)
    model = Geometry(np.array(m["base_joints_mm"], float), np.array(m["platform_joints_mm"], float),
                     np.array(m.get("strut_offset_mm", [0.0] * 6), float))
    return Machine(m["machine_id"], model, m["gravity"], m.get("friction", {}))


def perturbed_geometry(model, rng, base_mm, strut_mm):
    """The true machine: base joints moved uniformly within ±base_mm per coordinate, strut
    offsets within ±strut_mm; platform joints as in the model."""
    base = model.base + rng.uniform(-base_mm, base_mm, size=(6, 3))
    offsets = model.offsets + rng.uniform(-strut_mm, strut_mm, size=6)
    return Geometry(base, model.platform.copy(), offsets)


# ---------------------------------------------------------------------------------------------
# Kinematics ([PM-600 report] ch. 1): pose (X, Y, Z, A, B, C) of the tool tip,
# R = Rx(A)·Ry(B)·Rz(C) (eq. 1.4), P_j = X + R·(p_j + (0, 0, l)), strut length |P_j − Q_j|.


def _rx(a):
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1),
                     np.stack([z, s, c], -1)], -2)


def _ry(b):
    c, s, o, z = np.cos(b), np.sin(b), np.ones_like(b), np.zeros_like(b)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1),
                     np.stack([-s, z, c], -1)], -2)


def _rz(c_):
    c, s, o, z = np.cos(c_), np.sin(c_), np.ones_like(c_), np.zeros_like(c_)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1),
                     np.stack([z, z, o], -1)], -2)


def _d(rot, angle):
    """Derivative of an elementary rotation: d/dα R(α) = R(α + π/2) with the fixed axis zeroed."""
    d = rot(angle + np.pi / 2)
    fixed = {_rx: 0, _ry: 1, _rz: 2}[rot]
    d[..., fixed, :] = 0.0
    d[..., :, fixed] = 0.0
    return d


def rotation(ang):
    """R = Rx(A)·Ry(B)·Rz(C) for angles (..., 3) in radians → (..., 3, 3)."""
    return _rx(ang[..., 0]) @ _ry(ang[..., 1]) @ _rz(ang[..., 2])


def rotation_derivatives(ang):
    """∂R/∂A, ∂R/∂B, ∂R/∂C, each (..., 3, 3)."""
    rx, ry, rz = _rx(ang[..., 0]), _ry(ang[..., 1]), _rz(ang[..., 2])
    return (_d(_rx, ang[..., 0]) @ ry @ rz, rx @ _d(_ry, ang[..., 1]) @ rz,
            rx @ ry @ _d(_rz, ang[..., 2]))


def platform_vectors(geom, tool):
    """p_j + (0, 0, l): the platform joints relative to the tool tip, platform frame (6, 3)."""
    return geom.platform + np.array([0.0, 0.0, tool])


def platform_joints(x, ang, geom, tool):
    """P_j (N, 6, 3) for tip positions x (N, 3) and angles ang (N, 3)."""
    v = platform_vectors(geom, tool)
    return x[:, None, :] + np.einsum("nab,jb->nja", rotation(ang), v)


def strut_lengths(x, ang, geom, tool):
    """Joint-to-joint lengths |P_j − Q_j| (N, 6): the closed-form inverse kinematics."""
    return np.linalg.norm(platform_joints(x, ang, geom, tool) - geom.base, axis=-1)


def forward_kinematics(d, x0, ang0, geom, tool, tol=FK_TOLERANCE_MM, max_iter=30):
    """Pose (x, ang) whose joint-to-joint lengths are d (N, 6): Newton iteration from (x0, ang0)
    with the analytic Jacobian ∂L_j/∂X = u_j, ∂L_j/∂α = u_j·(∂R/∂α v_j)."""
    x, ang = x0.astype(float).copy(), ang0.astype(float).copy()
    v = platform_vectors(geom, tool)
    for _ in range(max_iter):
        diff = platform_joints(x, ang, geom, tool) - geom.base
        length = np.linalg.norm(diff, axis=-1)
        residual = length - d
        if np.max(np.abs(residual)) <= tol:
            return x, ang
        u = diff / length[..., None]
        jac = np.empty(d.shape + (6,))
        jac[..., :3] = u
        for k, dr in enumerate(rotation_derivatives(ang)):
            jac[..., 3 + k] = np.einsum("nja,nab,jb->nj", u, dr, v)
        step = np.linalg.solve(jac, -residual[..., None])[..., 0]
        x += step[:, :3]
        ang += step[:, 3:]
        # At the rounding floor of double precision the residual cannot fall further; a step
        # below the tolerance (angles weighted by a 1 m lever) is convergence too.
        if max(np.max(np.abs(step[:, :3])), 1000.0 * np.max(np.abs(step[:, 3:]))) <= tol:
            return x, ang
    raise RuntimeError("forward kinematics did not converge to %g mm (residual %g mm)"
                       % (tol, np.max(np.abs(residual))))


@dataclasses.dataclass
class StrutState:
    """Commanded strut geometry at N poses with the model geometry (docs/hexapod-effects.md:
    all statics use the commanded pose and the model geometry)."""
    P: np.ndarray  # (N, 6, 3) platform joints
    L: np.ndarray  # (N, 6) joint-to-joint lengths, mm
    u: np.ndarray  # (N, 6, 3) unit strut vectors from Q_j to P_j
    B: np.ndarray  # (N, 6, 3) P_j − tip
    R: np.ndarray  # (N, 3, 3)


def strut_state(x, ang, geom, tool):
    P = platform_joints(x, ang, geom, tool)
    diff = P - geom.base
    L = np.linalg.norm(diff, axis=-1)
    return StrutState(P, L, diff / L[..., None], P - x[:, None, :], rotation(ang))


# ---------------------------------------------------------------------------------------------
# Statics ([PM-600 report] eqs. 3.4–3.8)


def solve_tensions(s, force, moment):
    """Strut tensions x (N, 6), tension positive, from the platform's equilibrium
    Σ x_j l_j = force, Σ B_j × x_j l_j = moment ([PM-600 report] eqs. 3.4–3.6)."""
    a = np.concatenate([s.u, np.cross(s.B, s.u)], axis=-1)  # (N, 6 struts, 6 rows)
    rhs = np.concatenate([force, moment], axis=-1)
    return np.linalg.solve(np.swapaxes(a, -1, -2), rhs[..., None])[..., 0]


@dataclasses.dataclass
class GravityModel:
    """Masses, lengths and compliances of docs/hexapod-effects.md § gravity_deflection."""
    g: np.ndarray          # (3,) m/s²
    m_platform: float      # m_P, kg
    cog: np.ndarray        # platform centre of gravity, platform frame, mm
    m_screw: float         # m_B
    m_joint: float         # m_J
    m_motor: float         # m_S
    l1: float              # motor offset, mm
    l2: float              # platform joint length, mm
    l3: float              # ball screw length, mm
    m_strut: float         # m_T (eq. 3.8)
    k_stiff1: float        # mm/N (eq. 4.3)
    k_stiff2: float        # mm/N
    k1_factor: float = 1.0  # compliance form factors (1, 1 in the documented model)
    k2_factor: float = 1.0


def gravity_model(machine, k_stiff2=None, alt_mass=False):
    """The documented gravity model; `alt_mass` is the gravity_alt_mass variant: centre of
    gravity 40 mm sideways and 60 mm lower, platform mass +20 %, K_j = 1.3·K_stiff1 (L_j − l2)/l3
    + 0.9·K_stiff2."""
    gr = machine.gravity
    model = GravityModel(
        g=np.array(gr["g_mm_s2"], float) / 1000.0, m_platform=gr["platform_mass_kg"],
        cog=np.array(gr["platform_cog_mm"], float), m_screw=gr["ball_screw_mass_kg"],
        m_joint=gr["joint_mass_kg"], m_motor=gr["motor_mass_kg"], l1=gr["motor_offset_mm"],
        l2=gr["platform_joint_length_mm"], l3=gr["ball_screw_length_mm"],
        m_strut=gr["strut_equivalent_mass_kg"], k_stiff1=gr["compliance_screw_mm_per_N"],
        k_stiff2=gr["compliance_other_mm_per_N"] if k_stiff2 is None else k_stiff2)
    if alt_mass:
        model.cog = model.cog + np.array([40.0, 0.0, -60.0])
        model.m_platform *= 1.2
        model.k1_factor, model.k2_factor = 1.3, 0.9
    return model


def compliance(s, gm):
    """K_j = K_stiff1 (L_j − l2)/l3 + K_stiff2 ([PM-600 report] eq. 4.3), mm/N."""
    return gm.k1_factor * gm.k_stiff1 * (s.L - gm.l2) / gm.l3 + gm.k2_factor * gm.k_stiff2


@dataclasses.dataclass
class GravityForces:
    tension: np.ndarray  # x_j (N, 6)
    axial: np.ndarray    # F_j = x_j − m_T g·l_j (N, 6)
    carried: np.ndarray  # N_j (N, 6, 3)


def gravity_forces(s, gm, tool):
    """Strut tensions under the platform weight and the carried strut weight."""
    L = s.L
    # Strut weight carried at the platform joint, [PM-600 report] eq. 3.7.
    w = (gm.m_screw * (L - gm.l2 - gm.l3 / 2) + gm.m_joint * L - gm.m_motor * gm.l1) / L
    wg = w[..., None] * gm.g
    carried = wg - np.sum(wg * s.u, axis=-1)[..., None] * s.u
    weight = gm.m_platform * gm.g
    b_p = np.einsum("nab,b->na", s.R, gm.cog + np.array([0.0, 0.0, tool]))
    force = weight + carried.sum(axis=1)
    moment = np.cross(b_p, weight) + np.cross(s.B, carried).sum(axis=1)
    x = solve_tensions(s, force, moment)
    axial = x - gm.m_strut * (s.u @ gm.g)  # eqs. 3.5, 3.8: Γ(ĝ − g_s) = −[N_g; M_g]
    return GravityForces(x, axial, carried)


# ---------------------------------------------------------------------------------------------
# Effects: each returns Δs (N, 6) in mm for one test, from the commanded poses.


@dataclasses.dataclass
class CommandedPath:
    """One DBB test's commanded samples (rows in time order)."""
    x: np.ndarray       # (N, 3) commanded tool tip = moving ball
    ang: np.ndarray     # (N, 3) radians
    tool: float         # the file's tool_length_mm
    t: np.ndarray       # (N,) s since the first test's timestamp
    velocity: np.ndarray      # (N, 3) mm/s
    acceleration: np.ndarray  # (N, 3) mm/s²


def gravity_deflection(s, gm, tool):
    """docs/hexapod-effects.md § gravity_deflection: Δs_j = K_j F_j."""
    return compliance(s, gm) * gravity_forces(s, gm, tool).axial


def swing_axes(u):
    """a1 = unit(e_z × l_j) (e_x × l_j when l_j ∥ e_z), a2 = l_j × a1; (N, 6, 2, 3)."""
    a1 = np.cross(np.array([0.0, 0.0, 1.0]), u)
    norm = np.linalg.norm(a1, axis=-1)
    parallel = norm < 1e-12
    if np.any(parallel):
        a1[parallel] = np.cross(np.array([1.0, 0.0, 0.0]), u[parallel])
        norm = np.linalg.norm(a1, axis=-1)
    a1 = a1 / norm[..., None]
    return np.stack([a1, np.cross(u, a1)], axis=-2)


def friction_states(delta, ramp, exponential=False):
    """Friction state r_jk ∈ [−1, 1] after every sample for swings delta (N, 6, 2), mm.

    Linear ramp ([Joint patent] fig. 11): r ← clamp(r + 2δ/λ, −1, 1). The friction_exponential
    variant approaches the side of the motion exponentially, travel constant λ/3. The state
    starts from the steady state of the test's own motion: the samples are run through once
    before (docs/hexapod-effects.md § joint_friction)."""
    r = np.zeros(delta.shape[1:])
    out = np.empty_like(delta)
    for record in (False, True):
        for i in range(delta.shape[0]):
            d = delta[i]
            if exponential:
                side = np.sign(d)
                r = np.where(d != 0.0, side + (r - side) * np.exp(-np.abs(d) / (ramp / 3.0)), r)
            else:
                r = np.clip(r + 2.0 * d / ramp, -1.0, 1.0)
            if record:
                out[i] = r
    return out


def friction_forces(s, axial, torque, torque_per_n, ramp, exponential=False):
    """Forces f_j (N, 6, 3) of the base joints' resistance on the platform at P_j."""
    tau = torque + torque_per_n * np.abs(axial)  # N·m
    axes = swing_axes(s.u)
    # Swing between samples; the path is a closed circle run continuously, so the first sample
    # is reached from the last one.
    dP = s.P - np.roll(s.P, 1, axis=0)
    delta = np.einsum("njkc,njc->njk", axes, dP)
    r = friction_states(delta, ramp, exponential)
    return -(tau / (s.L / 1000.0))[..., None] * np.einsum("njk,njkc->njc", r, axes)


def joint_friction(s, gm, tool, params, exponential=False):
    """docs/hexapod-effects.md § joint_friction: Δs_j = K_j x_j, x from the friction forces."""
    axial = gravity_forces(s, gm, tool).axial
    f = friction_forces(s, axial, params["torque_Nm"], params["torque_per_N_m"],
                        params["ramp_mm"], exponential)
    x = solve_tensions(s, f.sum(axis=1), np.cross(s.B, f).sum(axis=1))
    return compliance(s, gm) * x


def servo_lag(s, path, geom, lag_ms2):
    """docs/hexapod-effects.md § servo_lag: Δs_j = (c/2)·s̈_j ([Fujita thesis] eq. 2.1 in strut
    space). The tilt is constant, so every platform joint moves with the tip:
    s̈ = (|Ṗ|² + (P − Q)·P̈ − ṡ²)/s with ṡ = (P − Q)·Ṗ/s."""
    diff = s.P - geom.base
    v = path.velocity[:, None, :]
    a = path.acceleration[:, None, :]
    s_dot = np.sum(diff * v, axis=-1) / s.L
    s_ddot = (np.sum(v * v, axis=-1) + np.sum(diff * a, axis=-1) - s_dot ** 2) / s.L
    return 0.5 * lag_ms2 * 1e-6 * s_ddot


# ---------------------------------------------------------------------------------------------
# The test plan ([PM-600 report] ch. 2: DBB tests with a jig of fixed-ball positions)

LEVEL_Z_MM = {1: -1150.0, 2: -1050.0, 3: -950.0}
HOLE_RING_MM = 100.0
TOOLS_MM = (104.255, 150.0)
# id, hole, level, A, B, C (degrees)
PLAN = [("a", 9, 1, 20, 0, 0), ("b", 4, 1, 0, 0, 0), ("c", 6, 1, -20, 0, 0),
        ("d", 8, 1, 0, 0, 0), ("e", 2, 1, 0, 20, 0), ("f", 9, 2, 0, 0, 0),
        ("g", 3, 2, 15, 0, 0), ("h", 5, 2, 0, 15, 0), ("i", 7, 2, -15, 0, 0),
        ("j", 1, 2, 0, -15, 0), ("k", 9, 3, 10, 10, 0), ("l", 4, 3, 0, 0, 0),
        ("m", 6, 3, -10, 0, 0), ("n", 8, 3, 0, -10, 0), ("o", 2, 3, 0, -20, 0)]
FEED_MM_MIN = 1000.0
TEST_INTERVAL_S = 150.0
START_TIME = "2026-03-10T08:00:00Z"


@dataclasses.dataclass
class DbbSpec:
    test_id: str
    direction: str  # "ccw" | "cw"
    centre: np.ndarray
    radius: float
    bar: float
    z_offset: float
    tilt_deg: tuple
    tool: float
    start_s: float  # seconds after START_TIME


def hole_centre(hole, level):
    """Jig holes 1–8 on a 100 mm ring every 45° (hole k at (k − 1)·45°), hole 9 at the centre."""
    if hole == 9:
        xy = (0.0, 0.0)
    else:
        phi = math.radians(45.0 * (hole - 1))
        xy = (round(HOLE_RING_MM * math.cos(phi), 9) + 0.0,
              round(HOLE_RING_MM * math.sin(phi), 9) + 0.0)
    return np.array([xy[0], xy[1], LEVEL_Z_MM[level]])


def jig_plan():
    """The 30 tests in the order they run: a-ccw, a-cw, b-ccw, …, 150 s apart. Level 2 rows
    are cone tests (radius 144, z_offset 42, bar 150); rows a–h use the 104.255 mm tool."""
    tests = []
    for tid, hole, level, a, b, c in PLAN:
        cone = level == 2
        for direction in ("ccw", "cw"):
            tests.append(DbbSpec(
                test_id=tid, direction=direction, centre=hole_centre(hole, level),
                radius=144.0 if cone else 150.0, bar=150.0, z_offset=42.0 if cone else 0.0,
                tilt_deg=(float(a), float(b), float(c)),
                tool=TOOLS_MM[0] if tid <= "h" else TOOLS_MM[1],
                start_s=TEST_INTERVAL_S * len(tests)))
    return tests


def commanded_path(spec, samples, feed=FEED_MM_MIN):
    """Commanded moving ball M(θ) = c + z_offset·e_z + R(cos θ, sin θ, 0), θ from 0 up (CCW)
    or down (CW) over one turn, exclusive; t_i = start + R·|θ_i − θ_0| / feed."""
    sign = 1.0 if spec.direction == "ccw" else -1.0
    theta = sign * 2.0 * np.pi * np.arange(samples) / samples
    cos, sin = np.cos(theta), np.sin(theta)
    ring = np.stack([cos, sin, np.zeros_like(theta)], axis=-1)
    x = spec.centre + np.array([0.0, 0.0, spec.z_offset]) + spec.radius * ring
    speed = feed / 60.0
    velocity = sign * speed * np.stack([-sin, cos, np.zeros_like(theta)], axis=-1)
    acceleration = -(speed ** 2 / spec.radius) * ring
    ang = np.tile(np.radians(np.array(spec.tilt_deg)), (samples, 1))
    t = spec.start_s + spec.radius * np.abs(theta - theta[0]) / speed
    return theta, CommandedPath(x, ang, spec.tool, t, velocity, acceleration)


# ---------------------------------------------------------------------------------------------
# Effect parameters


def parse_effect(text):
    """`NAME[:key=value,...]` → (name, {key: value})."""
    name, _, rest = text.partition(":")
    name = name.strip()
    if name not in EFFECTS:
        raise ValueError("unknown effect '%s' (known: %s)" % (name, ", ".join(EFFECTS)))
    params = {}
    for item in filter(None, (p.strip() for p in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq:
            raise ValueError("effect '%s': '%s' is not key=value" % (name, item))
        params[key.strip()] = float(value)
    return name, params


def tool_key(tool):
    return "error_um[%g]" % tool


def resolve_effects(specs, machine, tools=TOOLS_MM):
    """Every effect with all its parameters, defaults from the machine file."""
    fr = machine.friction
    defaults = {
        "gravity_deflection": {"K_stiff2_mm_per_N": machine.gravity["compliance_other_mm_per_N"]},
        "joint_friction": {"torque_Nm": fr.get("base_joint_torque_Nm", 0.0), "ramp_mm": 2.0,
                           "torque_per_N_m": fr.get("base_joint_torque_per_N_m", 0.0)},
        "tool_length_error": {tool_key(t): 0.0 for t in tools},
        "thermal_drift": {"rate_um_per_h": 20.0},
        "servo_lag": {"lag_coefficient_ms2": 1000.0},
    }
    aliases = {"K_stiff2": "K_stiff2_mm_per_N", "torque": "torque_Nm", "ramp": "ramp_mm",
               "rate": "rate_um_per_h", "lag": "lag_coefficient_ms2"}
    effects = {}
    for name, given in specs:
        params = dict(defaults[name])
        for key, value in given.items():
            key = aliases.get(key, key)
            if name == "tool_length_error" and not key.startswith("error_um["):
                key = tool_key(float(key))
            if key not in params:
                raise ValueError("effect '%s' has no parameter '%s' (known: %s)"
                                 % (name, key, ", ".join(params)))
            params[key] = value
        effects[name] = params
    if "joint_friction" in effects and not 0.01 <= effects["joint_friction"]["ramp_mm"] <= 50:
        raise ValueError("joint_friction: ramp_mm must be within 0.01–50 mm")
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


def effect_deflection(session, s, path, spec, drift_offset_s):
    """Σ Δs_j of the effects (N, 6), mm. One physical machine: the compliance (and, with
    gravity_alt_mass, the masses) of gravity_deflection also serve joint_friction; without
    gravity_deflection its K_stiff2 is the machine file's (docs/hexapod-effects.md)."""
    eff, var = session.effects, session.variants
    k2 = eff.get("gravity_deflection", {}).get("K_stiff2_mm_per_N")
    gm = gravity_model(session.machine, k2, "gravity_alt_mass" in var)
    ds = np.zeros(s.L.shape)
    if "gravity_deflection" in eff:
        ds += gravity_deflection(s, gm, spec.tool)
    if "joint_friction" in eff:
        ds += joint_friction(s, gm, spec.tool, eff["joint_friction"],
                             "friction_exponential" in var)
    if "thermal_drift" in eff:
        rate_mm_s = eff["thermal_drift"]["rate_um_per_h"] / 1000.0 / 3600.0
        if "drift_step" in var:
            ds += rate_mm_s * drift_offset_s
        else:
            ds += (rate_mm_s * path.t)[:, None]
    if "servo_lag" in eff:
        ds += servo_lag(s, path, session.machine.model, eff["servo_lag"]["lag_coefficient_ms2"])
    return ds


def tool_error_mm(session, tool):
    params = session.effects.get("tool_length_error", {})
    return params.get(tool_key(tool), 0.0) / 1000.0


def simulate_dbb(session, spec, drift_offset_s=0.0):
    """The bar readings of one test: (θ (rad), dr_um without noise, path)."""
    model, truth = session.machine.model, session.truth
    theta, path = commanded_path(spec, session.samples)
    s = strut_state(path.x, path.ang, model, spec.tool)
    commanded = s.L - model.offsets                        # controller: s_j
    d = commanded + truth.offsets + effect_deflection(session, s, path, spec, drift_offset_s)
    tip, _ = forward_kinematics(d, path.x, path.ang, truth,
                                spec.tool + tool_error_mm(session, spec.tool))
    bar = np.linalg.norm(tip - spec.centre, axis=-1)     # fixed ball F = c
    return theta, 1000.0 * (bar - spec.bar), path


def drift_steps(session, plan):
    """drift_step variant: the growth is constant within a test and jumps between tests; the
    last test has the linear drift's growth at the session's last sample. Returns per-test
    times (s) whose linear growth is that step."""
    if "drift_step" not in session.variants:
        return [0.0] * len(plan)
    end = plan[-1].start_s + 2.0 * np.pi * plan[-1].radius / (FEED_MM_MIN / 60.0) * \
        (session.samples - 1) / session.samples
    return [end * k / (len(plan) - 1) for k in range(len(plan))]


def gravity_sign_check(machine, effects, variants):
    """docs/hexapod-effects.md § gravity_deflection sign check: with gravity only, the tool tip
    moves −z at an untilted pose. Returns the tip displacement (mm)."""
    session = Session(machine, machine.model,
                      {"gravity_deflection": effects["gravity_deflection"]}, tuple(variants),
                      0.0, 1, np.random.default_rng(0))
    spec = DbbSpec("sign", "ccw", np.array([0.0, 0.0, LEVEL_Z_MM[1]]), 0.0, 0.0, 0.0,
                    (0.0, 0.0, 0.0), TOOLS_MM[0], 0.0)
    zero = np.zeros((1, 3))
    path = CommandedPath(spec.centre[None, :], zero, spec.tool, np.zeros(1), zero, zero)
    s = strut_state(path.x, path.ang, machine.model, spec.tool)
    d = s.L + effect_deflection(session, s, path, spec, 0.0)
    tip, _ = forward_kinematics(d, path.x, path.ang, machine.model, spec.tool)
    return (tip - path.x)[0]


def iso_time(start, seconds):
    t0 = datetime.datetime.strptime(start, "%Y-%m-%dT%H:%M:%SZ")
    return (t0 + datetime.timedelta(seconds=seconds)).strftime("%Y-%m-%dT%H:%M:%SZ")


def num(v):
    """Shortest text that reads back as the same number, integers without '.0'."""
    v = float(v) + 0.0
    return str(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)


def triple(v):
    return ", ".join(num(c) for c in v)


def dbb_text(machine_id, spec, theta, dr_um, start_time, temperature=None):
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
    if temperature is not None:
        lines.append("# temperature_c: %.3f" % temperature)
    lines.append("angle_deg,dr_um")
    lines += ["%.6f,%.6f" % (a, r) for a, r in zip(np.degrees(theta) + 0.0, dr_um + 0.0)]
    return "\n".join(lines) + "\n"


def file_name(spec):
    return "%s_%s.dbb" % (spec.test_id, spec.direction)


def simulate_session(session):
    """All tests of the plan in memory: list of (spec, θ, dr_um with noise)."""
    plan = jig_plan()
    results = []
    for spec, step_s in zip(plan, drift_steps(session, plan)):
        theta, dr, _ = simulate_dbb(session, spec, step_s)
        if session.noise_um > 0:
            dr = dr + session.rng.normal(0.0, session.noise_um, size=dr.shape)
        results.append((spec, theta, dr))
    return results


def make_session(machine, seed, noise_um, samples, perturb_base_mm, perturb_strut_mm, effects,
                 variants):
    rng = np.random.default_rng(seed)
    truth = perturbed_geometry(machine.model, rng, perturb_base_mm, perturb_strut_mm)
    for v in variants:
        if VARIANTS[v] not in effects:
            raise ValueError("variant '%s' changes %s, which is not among the effects"
                             % (v, VARIANTS[v]))
    return Session(machine, truth, effects, tuple(variants), noise_um, samples, rng)


def truth_json(args, session, sign_dz_um, files):
    t = session.truth
    return {
        "format": "kinemetric-sim-truth/1",
        "simulator": "tests/sim/hexapod_truth.py",
        "machine_id": session.machine.machine_id,
        "machine_file": os.path.relpath(os.path.abspath(args.machine), REPO),
        "seed": args.seed,
        "noise_um": session.noise_um,
        "samples_per_turn": session.samples,
        "perturbation": {"base_mm": args.perturb_base_mm, "strut_mm": args.perturb_strut_mm},
        "true_geometry": {"base_joints_mm": t.base.tolist(),
                          "platform_joints_mm": t.platform.tolist(),
                          "strut_offset_mm": t.offsets.tolist()},
        "effects": [{"effect": name, "parameters": params}
                    for name, params in session.effects.items()],
        "variants": list(session.variants),
        "gravity_sign_check_tip_dz_um": sign_dz_um,
        "files": files,
    }


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="output directory (created)")
    p.add_argument("--machine", default=DEFAULT_MACHINE, help="machine file (the model)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--noise-um", type=float, default=0.3)
    p.add_argument("--samples", type=int, default=720, help="samples per turn")
    p.add_argument("--perturb-base-mm", type=float, default=0.3)
    p.add_argument("--perturb-strut-mm", type=float, default=0.1)
    p.add_argument("--effect", action="append", default=[], help="NAME[:key=value,...]")
    p.add_argument("--variant", action="append", default=[], choices=sorted(VARIANTS))
    p.add_argument("--temperature", action="store_true",
                   help="write temperature_c (rising by --heating-k-per-h from 20 °C)")
    p.add_argument("--heating-k-per-h", type=float, default=1.0)
    p.add_argument("--start-time", default=START_TIME)
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(argv)
    started = time.monotonic()
    machine = load_machine(args.machine)
    try:
        effects = resolve_effects([parse_effect(e) for e in args.effect], machine)
        session = make_session(machine, args.seed, args.noise_um, args.samples,
                               args.perturb_base_mm, args.perturb_strut_mm, effects,
                               args.variant)
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
    results = simulate_session(session)
    os.makedirs(args.out, exist_ok=True)
    files = []
    for spec, theta, dr in results:
        temperature = None
        if args.temperature:
            temperature = 20.0 + args.heating_k_per_h * spec.start_s / 3600.0
        with open(os.path.join(args.out, file_name(spec)), "w", encoding="utf-8") as f:
            f.write(dbb_text(machine.machine_id, spec, theta, dr, args.start_time, temperature))
        files.append(file_name(spec))
    with open(os.path.join(args.out, "truth.json"), "w", encoding="utf-8") as f:
        json.dump(truth_json(args, session, sign_dz_um, files), f, indent=2)
        f.write("\n")
    print("hexapod_truth: %d files in %s (%.1f s)" % (len(files), args.out,
                                                      time.monotonic() - started))
    return 0


if __name__ == "__main__":
    sys.exit(main())
