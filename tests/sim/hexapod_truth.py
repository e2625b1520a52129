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

Units: lengths mm, forces N, torques N·m, masses kg, times s; angles degrees in files and
radians inside. The report's SI lengths (m) appear only where the report's constants need
them: f_t,j/L_j with L_j in m (eq. 3.11), t1 in m (eq. 3.12).

Conventions where the sources leave a choice (each one named so that a reader can object):

 1. Strut direction. l_j = (P_j − Q_j)/L_j, from the base joint Q_j to the platform joint P_j:
    eq. 1.2 defines the strut vector L_j = P_j − Q_j, and eq. 3.11 differentiates L_j·l_j, which
    is that vector. B_j = P_j − tool tip, B_P = platform centre of gravity − tool tip.
 2. Sign of the strut force. With that l_j, eq. 3.5 Γ(ĝ − g_s) = −[N_g; M_g] makes ĝ_j − g_s,j
    the force strut j pushes onto the platform (compression positive); a hanging platform gives
    ĝ_j < 0. Eq. 4.2 ΔL_j = K_j·F_E,j read with that sign would shorten a strut in tension and
    lift the tool. The simulator uses the tension F_j = −ĝ_j in eq. 4.2, so that a strut in
    tension grows and the tool sags (−z), and keeps the rest of eq. 3.5 as printed:
        F = Γ⁻¹([N_g; M_g]) − g_s,  g_s,j = m_T g·l_j            (eqs. 3.5, 3.8)
    For a hanging strut g·l_j > 0: the axial weight of the strut's equivalent mass m_T lowers
    the tension that deflects it (the report's sign). Variant `gravity_weight_adds`: the other
    reading, F = Γ⁻¹([N_g; M_g]) + g_s (the axial weight adds to the tension).
 3. N_g, M_g (eqs. 3.6-3.7): N_g = m_P g + Σ N_g,j, M_g = B_P × m_P g + Σ B_j × N_g,j with
    N_g,j = w_j g − (w_j g·l_j) l_j and w_j = (m_B (L_j − l2 − l3/2) + m_J L_j − m_S l1)/L_j,
    exactly as printed (the strut weight acts on the platform as the moment about the base
    joint, only normal to the strut). The statics use the true joint positions at the
    commanded pose.
 4. Compliance (eq. 4.3): K_j = K_stiff1 (L_j − l2)/l3 + K_stiff2, L_j the joint-to-joint
    length at the sample; the same K_j serves every force (eqs. 4.1-4.2). Inertia F̂ (eq. 3.13)
    and the ball-screw friction f_b (excluded by eq. 4.1) do not deflect the struts.
 5. Joint friction (eqs. 3.9-3.12). The base joint's friction torque acts on the platform as
    one force at P_j of size f_t,j/L_j (L_j in m) opposing the joint's motion:
        f_j = −(f_t,j / L_j) · r_j,  f_t,j = t0 + t1·|F_j|
    |F_j| is the size of the strut's axial gravity force of convention 2 (eq. 3.12's ĝ_j). Its
    size, not its sign: on the pm600-like machine some struts are in compression at the off-centre
    poses of the plan (down to about −1400 N), where a signed ĝ_j would make f_t negative.
    Default: r_j = the unit vector of the platform joint's commanded velocity normal to the
    strut, (I − l_j l_jᵀ) Ṗ_j (fig. 3.4 draws the force normal to the strut; the axial part
    belongs to the ball screw, eq. 3.10). Variant `friction_literal`: r_j = unit(d(L_j l_j)/dt)
    = unit(Ṗ_j), the full velocity as eq. 3.11 prints it. The friction forces load the struts
    through the platform statics, F_c = Γ⁻¹([N_c; M_c]) with N_c = Σ f_j, M_c = Σ B_j × f_j
    (eq. 3.9, tension positive as in convention 2), and deflect them with the K_j of eq. 4.3.
 6. Friction after a reversal ([Joint patent] figs. 8, 10-12, claim 3). ramp_mm = 0 is eq. 3.11:
    the force turns at once. ramp_mm = λ > 0: the state r_j is a vector in the plane normal to
    the strut (the full space with friction_literal), |r_j| ≤ 1, moved by the joint's commanded
    travel δ_j between samples: r_j ← P_disk(r_j + 2 δ_j/λ) (P_disk rescales to length 1 when
    longer). A reversal along one line turns r_j from −1 to +1 linearly over a travel λ of the
    platform joint, then it stays: the patent's linear change. The travel is the commanded one
    (the deflections do not feed back), so reversals come from the commanded motion only. A
    closed full turn starts from its own steady state (the turn is run through once before); a
    path that is not closed (partial arc, lead-in) starts with r_j fully developed along its
    first motion.
 7. Thermal drift: every strut grows by rate_um_per_h·t (uniform), and by
    strain_ppm_per_h·1e-6·L_j·t (α·L·ΔT with ΔT ∝ t, L_j the joint-to-joint length at the
    sample), t in hours since the first test's time stamp.
 8. Tool length: the real tool is the programmed one plus error_um; the tip moves along −R e_z.
 9. Servo lag: Δs_j = (c/2)·s̈_j in strut space (as before; c in ms²).
10. The real machine: base joints moved uniformly within ±perturb_base_mm per coordinate, strut
    offsets within ±perturb_strut_mm (the 24 parameters the product calibrates) and, with
    --platform-joint-error-mm E, every platform joint coordinate moved by ±E (random sign),
    an error outside that 24-parameter model.
11. Noise: white (σ = --noise-um per sample) or `ar1`: an AR(1) series with ρ = 0.97 per sample
    (80 % of the variance) plus a slow random wander (a random walk over the test, its mean
    removed, 20 % of the variance); each test's sum is scaled to RMS = --noise-um.
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
# variant → the effects it changes (one of them must be simulated)
VARIANTS = {"friction_literal": ("joint_friction",),
            "gravity_weight_adds": ("gravity_deflection", "joint_friction")}
NOISE_MODELS = ("white", "ar1")
AR1_RHO = 0.97
AR1_SHARE = 0.8  # share of the variance in the AR(1) part; the rest is the slow wander

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


def perturbed_geometry(model, rng, base_mm, strut_mm, platform_mm=0.0):
    """The true machine: base joints moved uniformly within ±base_mm per coordinate, strut
    offsets within ±strut_mm, platform joints by ±platform_mm per coordinate (random sign)."""
    base = model.base + rng.uniform(-base_mm, base_mm, size=(6, 3))
    offsets = model.offsets + rng.uniform(-strut_mm, strut_mm, size=6)
    platform = model.platform.copy()
    if platform_mm > 0.0:
        platform += platform_mm * rng.choice([-1.0, 1.0], size=(6, 3))
    return Geometry(base, platform, offsets)


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
    return x[:, None, :] + np.swapaxes(rotation(ang) @ v.T, -1, -2)


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
    """Strut geometry at N poses."""
    P: np.ndarray  # (N, 6, 3) platform joints
    L: np.ndarray  # (N, 6) joint-to-joint lengths, mm
    u: np.ndarray  # (N, 6, 3) l_j: unit strut vectors from Q_j to P_j
    B: np.ndarray  # (N, 6, 3) B_j = P_j − tip
    R: np.ndarray  # (N, 3, 3)


def strut_state(x, ang, geom, tool):
    P = platform_joints(x, ang, geom, tool)
    diff = P - geom.base
    L = np.linalg.norm(diff, axis=-1)
    return StrutState(P, L, diff / L[..., None], P - x[:, None, :], rotation(ang))


# ---------------------------------------------------------------------------------------------
# Statics ([PM-600 report] eq. 3.4)


def gamma_matrix(s):
    """Γ_{l,B} of eq. 3.4 as a matrix (N, 6 rows, 6 struts): Γ(x) = Σ x_j [l_j; B_j × l_j]."""
    return np.swapaxes(np.concatenate([s.u, np.cross(s.B, s.u)], axis=-1), -1, -2)


def gamma_solve(s, force, moment):
    """x (N, 6) with Γ_{l,B}(x) = [force; moment] (eq. 3.4)."""
    rhs = np.concatenate([force, moment], axis=-1)
    return np.linalg.solve(gamma_matrix(s), rhs[..., None])[..., 0]


# ---------------------------------------------------------------------------------------------
# Gravity ([PM-600 report] eqs. 3.5-3.8) and compliance (eq. 4.3)


@dataclasses.dataclass
class GravityModel:
    g: np.ndarray          # (3,) m/s²
    m_platform: float      # m_P, kg
    cog: np.ndarray        # platform centre of gravity, platform frame, mm
    m_screw: float         # m_B
    m_joint: float         # m_J
    m_motor: float         # m_S
    l1: float              # motor offset behind the base joint, mm
    l2: float              # platform joint length, mm
    l3: float              # ball screw length, mm
    m_strut: float         # m_T (eq. 3.8)
    k_stiff1: float        # mm/N (eq. 4.3)
    k_stiff2: float        # mm/N
    weight_adds: bool = False  # variant gravity_weight_adds


def gravity_model(machine, params=None, weight_adds=False):
    """The machine's masses and compliances; `params` (gravity_deflection's) override
    K_stiff2, K_stiff1, the platform mass and its centre of gravity."""
    gr, p = machine.gravity, dict(params or {})
    cog = p.get("platform_cog_mm")
    return GravityModel(
        g=np.array(gr.get("g_mm_s2", [0.0, 0.0, -9806.65]), float) / 1000.0,
        m_platform=p.get("platform_mass_kg", gr["platform_mass_kg"]),
        cog=np.array(gr["platform_cog_mm"] if cog is None else cog, float),
        m_screw=gr["ball_screw_mass_kg"], m_joint=gr["joint_mass_kg"],
        m_motor=gr["motor_mass_kg"], l1=gr["motor_offset_mm"],
        l2=gr["platform_joint_length_mm"], l3=gr["ball_screw_length_mm"],
        m_strut=gr["strut_equivalent_mass_kg"],
        k_stiff1=p.get("K_stiff1_mm_per_N", gr["compliance_screw_mm_per_N"]),
        k_stiff2=p.get("K_stiff2_mm_per_N", gr["compliance_other_mm_per_N"]),
        weight_adds=weight_adds)


def compliance(s, gm):
    """K_j = K_stiff1 (L_j − l2)/l3 + K_stiff2 (eq. 4.3), mm/N."""
    return gm.k_stiff1 * (s.L - gm.l2) / gm.l3 + gm.k_stiff2


def gravity_load(s, gm, tool):
    """N_g (N, 3) in N and M_g (N, 3) in N·mm about the tool tip (eqs. 3.6-3.7)."""
    L = s.L
    w = (gm.m_screw * (L - gm.l2 - gm.l3 / 2.0) + gm.m_joint * L - gm.m_motor * gm.l1) / L
    wg = w[..., None] * gm.g                                   # (N, 6, 3)
    n_j = wg - np.sum(wg * s.u, axis=-1)[..., None] * s.u      # N_g,j
    weight = gm.m_platform * gm.g
    b_p = np.einsum("nab,b->na", s.R, gm.cog + np.array([0.0, 0.0, tool]))
    n_g = weight + n_j.sum(axis=1)
    m_g = np.cross(b_p, weight) + np.cross(s.B, n_j).sum(axis=1)
    return n_g, m_g


def gravity_tension(s, gm, tool):
    """Axial gravity force of each strut, tension positive (N, 6), N: convention 2,
    F = Γ⁻¹([N_g; M_g]) − g_s (variant gravity_weight_adds: + g_s), g_s,j = m_T g·l_j."""
    n_g, m_g = gravity_load(s, gm, tool)
    g_s = gm.m_strut * (s.u @ gm.g)
    return gamma_solve(s, n_g, m_g) + (g_s if gm.weight_adds else -g_s)


def gravity_deflection(s, gm, tool):
    """Δs_j = K_j F_j (eqs. 4.2-4.3), mm."""
    return compliance(s, gm) * gravity_tension(s, gm, tool)


# ---------------------------------------------------------------------------------------------
# Joint friction ([PM-600 report] eqs. 3.9-3.12, [Joint patent] figs. 10-12)


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0.0)


def _normal_part(v, u):
    return v - np.sum(v * u, axis=-1)[..., None] * u


def friction_directions(s, travel, ramp, literal, closed):
    """r_j (N, 6, 3): the unit (or, on a ramp, shorter) direction of each base joint's
    resistance, from the commanded travel of the platform joints between samples (N, 6, 3)."""
    return ramp_states(travel, s.u, ramp, literal, closed)


def ramp_states(travel, u, ramp, literal, closed):
    """The friction states of convention 6 for travels and strut directions (..., N, 6, 3), the
    sample axis third from the end (leading axes: tests run side by side)."""
    delta = travel if literal else _normal_part(travel, u)
    if ramp <= 0.0:
        return _unit(delta)
    out = np.empty_like(delta)
    r = _unit(delta[..., 0, :, :])
    step = 2.0 * delta / ramp
    for record in ((False, True) if closed else (True,)):
        for i in range(delta.shape[-3]):
            if not literal:
                ui = u[..., i, :, :]
                r = r - np.sum(r * ui, axis=-1, keepdims=True) * ui
            r = r + step[..., i, :, :]
            norm = np.sqrt(np.sum(r * r, axis=-1, keepdims=True))
            r = r / np.maximum(norm, 1.0)
            if record:
                out[..., i, :, :] = r
    return out


def friction_forces(s, tension, params, travel, literal, closed, states=None):
    """Forces f_j (N, 6, 3) in N of the base joints' friction at the platform joints (eq. 3.11);
    `states`: the r_j when already computed."""
    f_t = params["torque_Nm"] + params["torque_per_N_m"] * np.abs(tension)   # N·m, eq. 3.12
    size = f_t / (s.L / 1000.0)                                              # N
    r = friction_directions(s, travel, params["ramp_mm"], literal, closed) if states is None \
        else states
    return -size[..., None] * r


def friction_tension(s, forces):
    """Strut tensions (N, 6) carrying the friction forces (eq. 3.9, tension positive)."""
    return gamma_solve(s, forces.sum(axis=1), np.cross(s.B, forces).sum(axis=1))


def joint_friction(s, gm, tool, params, travel, literal=False, closed=True, states=None):
    """Δs_j = K_j F_c,j, mm."""
    tension = gravity_tension(s, gm, tool)
    forces = friction_forces(s, tension, params, travel, literal, closed, states)
    return compliance(s, gm) * friction_tension(s, forces)


# ---------------------------------------------------------------------------------------------
# Servo lag and thermal drift


def servo_lag(s, path, geom, lag_ms2):
    """Δs_j = (c/2)·s̈_j in strut space. The tilt is constant, so every platform joint moves
    with the tip: s̈ = (|Ṗ|² + (P − Q)·P̈ − ṡ²)/s with ṡ = (P − Q)·Ṗ/s."""
    diff = s.P - geom.base
    v = path.velocity[:, None, :]
    a = path.acceleration[:, None, :]
    s_dot = np.sum(diff * v, axis=-1) / s.L
    s_ddot = (np.sum(v * v, axis=-1) + np.sum(diff * a, axis=-1) - s_dot ** 2) / s.L
    return 0.5 * lag_ms2 * 1e-6 * s_ddot


def thermal_drift(s, path, params):
    """Strut growth (N, 6), mm: uniform rate plus strain ∝ joint-to-joint length."""
    hours = (path.t / 3600.0)[:, None]
    return (params["rate_um_per_h"] / 1000.0) * hours + \
        params["strain_ppm_per_h"] * 1e-6 * s.L * hours


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
    are cone tests (radius 144, z_offset 42, bar 150; [PM-600 report] § 4.2.4); rows a–h use
    the 104.255 mm tool."""
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


@dataclasses.dataclass
class CommandedPath:
    """One DBB test's commanded samples (rows in time order)."""
    theta: np.ndarray         # (N,) commanded angle about the centre, rad (decreasing for cw)
    x: np.ndarray             # (N, 3) commanded tool tip = moving ball
    ang: np.ndarray           # (N, 3) radians
    tool: float               # the file's tool_length_mm
    t: np.ndarray             # (N,) s since the first test's time stamp
    velocity: np.ndarray      # (N, 3) mm/s
    acceleration: np.ndarray  # (N, 3) mm/s²
    dt: float                 # s between samples
    closed: bool              # a full turn without lead-in: the last sample runs into the first
    friction_states: np.ndarray = None  # r_j (N, 6, 3) when computed for the whole plan at once


def commanded_path(spec, samples, arc_deg=360.0, lead_mm=0.0, feed=FEED_MM_MIN):
    """Commanded moving ball M(θ) = c + z_offset·e_z + R(cos θ, sin θ, 0). A full turn without
    lead: θ from 0 up (CCW) or down (CW) over one turn, exclusive, `samples` points. Otherwise θ
    runs from −lead to arc + lead (lead = lead_mm / R) inclusive at about the same spacing.
    t_i = start + R·|θ_i − θ_0| / feed."""
    sign = 1.0 if spec.direction == "ccw" else -1.0
    step = 2.0 * np.pi / samples
    arc = math.radians(arc_deg)
    lead = lead_mm / spec.radius
    closed = arc_deg >= 360.0 and lead_mm <= 0.0
    if closed:
        theta = step * np.arange(samples)
    else:
        n = int(round((arc + 2.0 * lead) / step)) + 1
        theta = np.linspace(-lead, arc + lead, n)
    theta = sign * theta
    cos, sin = np.cos(theta), np.sin(theta)
    ring = np.stack([cos, sin, np.zeros_like(theta)], axis=-1)
    x = spec.centre + np.array([0.0, 0.0, spec.z_offset]) + spec.radius * ring
    speed = feed / 60.0
    velocity = sign * speed * np.stack([-sin, cos, np.zeros_like(theta)], axis=-1)
    acceleration = -(speed ** 2 / spec.radius) * ring
    ang = np.tile(np.radians(np.array(spec.tilt_deg)), (theta.size, 1))
    t = spec.start_s + spec.radius * np.abs(theta - theta[0]) / speed
    dt = spec.radius * abs(theta[1] - theta[0]) / speed
    return CommandedPath(theta, x, ang, spec.tool, t, velocity, acceleration, dt, closed)


def joint_travel(path):
    """Commanded travel of every platform joint from one sample to the next (N, 6, 3), mm: the
    tilt is constant, so each joint moves with the tip, Ṗ_j = Ẋ."""
    return np.broadcast_to((path.velocity * path.dt)[:, None, :], (path.x.shape[0], 6, 3))


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
