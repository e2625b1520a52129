#!/usr/bin/python3
"""Physics of the hexapod truth simulator (hexapod_truth.py): the machine's geometry and
kinematics, the platform statics, gravity and compliance, joint friction, servo lag, thermal
drift and the jig's test plan, written from the source documents alone ([PM-600 report] ch. 1-4,
[Joint patent]). It shares no code with the C++ analysis it judges.

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

import dataclasses
import json
import math
import os

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
