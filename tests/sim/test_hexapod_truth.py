#!/usr/bin/python3
"""First-principle checks of the truth simulator tests/sim/hexapod_truth.py: statics, signs,
sizes and kinematics that need no other simulator ([PM-600 report] ch. 1, 3, 4; [Joint patent]).

  /usr/bin/python3 tests/sim/test_hexapod_truth.py [-v]

Prints the friction lag it measures (table 3.2's torques) with -v.
"""

import json
import os
import sys
import tempfile
import time
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hexapod_physics as hp  # noqa: E402
import hexapod_truth as ht  # noqa: E402

MACHINE = hp.load_machine(hp.DEFAULT_MACHINE)
TOOL = hp.TOOLS_MM[0]
TABLE_3_2 = {"torque_Nm": 8.88, "torque_per_N_m": 0.0139, "ramp_mm": 0.0}


def session(effects=(), variants=(), perturb=(0.0, 0.0), noise=0.0, seed=1, samples=720, **kw):
    eff = ht.resolve_effects([ht.parse_effect(e) for e in effects], MACHINE)
    return ht.make_session(MACHINE, seed, noise, samples, perturb[0], perturb[1], eff, variants,
                           **kw)


def untilted_test(direction="ccw", level=1):
    """Row-b-like test at the jig centre: untilted, radius 150, fixed ball at the centre."""
    return hp.DbbSpec("u", direction, hp.hole_centre(9, level), 150.0, 150.0, 0.0,
                      (0.0, 0.0, 0.0), TOOL, 0.0)


def state(spec, ses=None, samples=720):
    path = hp.commanded_path(spec, samples)
    geom = MACHINE.model if ses is None else ses.truth
    return path, hp.strut_state(path.x, path.ang, geom, spec.tool)


def deflection(ses, spec):
    """Σ Δs (N, 6) of the session's effects along the test's commanded path."""
    path, s = state(spec, ses, ses.samples)
    return ht.effect_deflection(ses, s, path, spec)


def tip_shift(ds, x, ang, tool=TOOL):
    """Tip displacement (N, 3), mm, when the struts of the model machine grow by ds at (x, ang)."""
    d = hp.strut_lengths(x, ang, MACHINE.model, tool) + ds
    tip, _ = hp.forward_kinematics(d, x, ang, MACHINE.model, tool)
    return tip - x


class Kinematics(unittest.TestCase):
    def test_rotation_derivatives_match_finite_differences(self):
        ang = np.radians(np.array([[12.0, -7.0, 30.0]]))
        h = 1e-7
        for k, analytic in enumerate(hp.rotation_derivatives(ang)):
            step = np.zeros(3)
            step[k] = h
            numeric = (hp.rotation(ang + step) - hp.rotation(ang - step)) / (2 * h)
            np.testing.assert_allclose(analytic, numeric, atol=1e-8)

    def test_rotation_order_is_rx_ry_rz(self):
        # [PM-600 report] eq. 1.4: a pure A tilt turns +y towards +z.
        r = hp.rotation(np.radians(np.array([[90.0, 0.0, 0.0]])))[0]
        np.testing.assert_allclose(r @ [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], atol=1e-15)
        a, b, c = np.radians([10.0, 20.0, 30.0])
        expected = hp._rx(np.array(a)) @ hp._ry(np.array(b)) @ hp._rz(np.array(c))
        np.testing.assert_allclose(hp.rotation(np.array([a, b, c])), expected, atol=1e-15)

    def test_ik_fk_round_trip(self):
        rng = np.random.default_rng(7)
        geom = hp.perturbed_geometry(MACHINE.model, rng, 0.3, 0.1)
        n = 500
        x = np.c_[rng.uniform(-200, 200, (n, 2)), rng.uniform(-1200, -900, n)]
        ang = np.radians(rng.uniform(-25, 25, (n, 3)))
        d = hp.strut_lengths(x, ang, geom, TOOL)
        x0 = x + rng.uniform(-1, 1, (n, 3))
        ang0 = ang + rng.uniform(-0.01, 0.01, (n, 3))
        xf, af = hp.forward_kinematics(d, x0, ang0, geom, TOOL)
        self.assertLess(np.max(np.abs(xf - x)), 1e-9)
        self.assertLess(np.max(np.abs(af - ang)) * 1000.0, 1e-9)  # 1 m lever
        self.assertLess(np.max(np.abs(hp.strut_lengths(xf, af, geom, TOOL) - d)), 1e-12)

    def test_longer_real_tool_moves_tip_along_minus_spindle_axis(self):
        # tool_length_error: error = real − programmed; at a fixed platform pose the tip moves
        # by −error along the spindle axis R·e_z.
        x = np.array([[30.0, -40.0, -1050.0]])
        ang = np.radians(np.array([[15.0, -10.0, 5.0]]))
        d = hp.strut_lengths(x, ang, MACHINE.model, TOOL)
        error = 0.062
        xf, af = hp.forward_kinematics(d, x, ang, MACHINE.model, TOOL + error)
        axis = hp.rotation(ang)[0] @ [0.0, 0.0, 1.0]
        np.testing.assert_allclose(xf[0], x[0] - error * axis, atol=1e-10)
        np.testing.assert_allclose(af, ang, atol=1e-14)


class Gravity(unittest.TestCase):
    def test_tool_sags_at_untilted_pose(self):
        for variants in ((), ("gravity_weight_adds",)):
            effects = ht.resolve_effects([("gravity_deflection", {})], MACHINE)
            dz_um = 1000.0 * ht.gravity_sign_check(MACHINE, effects, variants)[2]
            self.assertLess(dz_um, -1.0, variants)
            self.assertGreater(dz_um, -200.0, variants)

    def test_hanging_platform_struts_in_tension_and_statics_balance(self):
        gm = hp.gravity_model(MACHINE)
        for level in (1, 2, 3):
            x = hp.hole_centre(9, level)[None, :]
            s = hp.strut_state(x, np.zeros((1, 3)), MACHINE.model, TOOL)
            self.assertTrue(np.all(s.u[..., 2] < 0.0))  # the platform hangs below its joints
            n_g, m_g = hp.gravity_load(s, gm, TOOL)
            x_platform = hp.gamma_solve(s, n_g, m_g)
            self.assertTrue(np.all(x_platform > 0.0), x_platform)      # tension
            tension = hp.gravity_tension(s, gm, TOOL)
            self.assertTrue(np.all(tension > 0.0), tension)
            # Γ(x) = [N_g; M_g] (eq. 3.4): forces and moments about the tool tip balance.
            np.testing.assert_allclose(np.sum(x_platform[0][:, None] * s.u[0], axis=0), n_g[0],
                                       atol=1e-9 * np.abs(n_g).max())
            moment = np.sum(np.cross(s.B[0], x_platform[0][:, None] * s.u[0]), axis=0)
            scale = gm.m_platform * np.linalg.norm(gm.g) * 1000.0   # N·mm: weight × 1 m
            np.testing.assert_allclose(moment, m_g[0], rtol=1e-9, atol=1e-12 * scale)
            # N_g holds the platform's whole weight plus the struts' shares normal to them.
            self.assertLess(n_g[0, 2], gm.m_platform * gm.g[2])
            # Eq. 3.5 as printed: the axial weight m_T g·l_j lowers the tension; the variant
            # gravity_weight_adds adds it.
            g_s = gm.m_strut * (s.u @ gm.g)
            np.testing.assert_allclose(tension, x_platform - g_s, rtol=1e-12)
            gm_adds = hp.gravity_model(MACHINE, weight_adds=True)
            np.testing.assert_allclose(hp.gravity_tension(s, gm_adds, TOOL), x_platform + g_s,
                                       rtol=1e-12)

    def test_deflection_is_compliance_times_tension(self):
        gm = hp.gravity_model(MACHINE, {"K_stiff2_mm_per_N": 1.37e-5})
        _, s = state(untilted_test())
        k = 9e-6 * (s.L - 150.0) / 1000.0 + 1.37e-5                       # eq. 4.3
        np.testing.assert_allclose(hp.compliance(s, gm), k, rtol=1e-12)
        np.testing.assert_allclose(hp.gravity_deflection(s, gm, TOOL),
                                   k * hp.gravity_tension(s, gm, TOOL), rtol=1e-12)
        centre = hp.strut_state(hp.hole_centre(9, 1)[None, :], np.zeros((1, 3)), MACHINE.model,
                                TOOL)
        self.assertTrue(np.all(hp.gravity_deflection(centre, gm, TOOL) > 0.0))  # struts stretch

    def test_heavy_off_axis_platform(self):
        # A 275 kg platform sags more; its centre of gravity moved +x tilts the platform so that
        # the tip (below the joints) swings towards −x... whichever way, it must move in x.
        x = hp.hole_centre(9, 1)[None, :]
        ang = np.zeros((1, 3))
        s = hp.strut_state(x, ang, MACHINE.model, TOOL)
        base = hp.gravity_deflection(s, hp.gravity_model(MACHINE), TOOL)
        heavy = hp.gravity_deflection(s, hp.gravity_model(MACHINE, {"platform_mass_kg": 275.0}),
                                      TOOL)
        off = hp.gravity_deflection(s, hp.gravity_model(
            MACHINE, {"platform_mass_kg": 275.0, "platform_cog_mm": [40.0, 0.0, 180.0]}), TOOL)
        dz = [tip_shift(d, x, ang)[0, 2] for d in (base, heavy)]
        self.assertLess(dz[1], dz[0])
        self.assertGreater(abs(tip_shift(off, x, ang)[0, 0]), 1e-4)       # > 0.1 µm sideways
        self.assertAlmostEqual(tip_shift(base, x, ang)[0, 0], 0.0, delta=1e-4)


class Friction(unittest.TestCase):
    def friction_at(self, spec, literal=False, params=TABLE_3_2):
        path, s = state(spec)
        gm = hp.gravity_model(MACHINE)
        tension = hp.gravity_tension(s, gm, TOOL)
        forces = hp.friction_forces(s, tension, params, hp.joint_travel(path), literal, True)
        return path, s, tension, forces

    def test_force_opposes_the_swing_with_size_ft_over_L(self):
        for direction in ("ccw", "cw"):
            spec = untilted_test(direction)
            path, s, tension, f = self.friction_at(spec)
            f_t = 8.88 + 0.0139 * np.abs(tension)
            size = np.linalg.norm(f, axis=-1)
            np.testing.assert_allclose(size, f_t / (s.L / 1000.0), rtol=1e-12)   # eq. 3.11
            v = np.broadcast_to(path.velocity[:, None, :], f.shape)
            swing = v - np.sum(v * s.u, axis=-1)[..., None] * s.u
            # normal to the strut and exactly against the swing
            np.testing.assert_allclose(np.sum(f * s.u, axis=-1), 0.0, atol=1e-9)
            cos = np.sum(f * swing, axis=-1) / (size * np.linalg.norm(swing, axis=-1))
            np.testing.assert_allclose(cos, -1.0, atol=1e-12)
            # friction_literal: against the full velocity d(L_j l_j)/dt = Ṗ_j
            _, _, _, fl = self.friction_at(spec, literal=True)
            cos = np.sum(fl * v, axis=-1) / (np.linalg.norm(fl, axis=-1)
                                              * np.linalg.norm(v, axis=-1))
            np.testing.assert_allclose(cos, -1.0, atol=1e-12)
            np.testing.assert_allclose(np.linalg.norm(fl, axis=-1), size, rtol=1e-12)

    def test_tool_lags_its_command(self):
        # Table 3.2's torques, the report's condition C (R 150 at Z −1215, untilted, table 3.3).
        results = {}
        for variants in ((), ("friction_literal",)):
            for z in (-1215.0, hp.LEVEL_Z_MM[1]):
                along, radial = ht.friction_lag(MACHINE, TABLE_3_2, variants, z_mm=z)
                results[(variants, z)] = along
                self.assertLess(abs(radial), 0.01)
        along = results[((), -1215.0)]
        self.assertLess(along, -1.5)
        self.assertGreater(along, -2.5)
        self.assertLess(results[((), hp.LEVEL_Z_MM[1])], -1.0)
        if "-v" in sys.argv:
            print("\n  friction lag along the path, table 3.2 torques: %s" % ", ".join(
                "%s Z=%g: %+.3f µm" % (v[0] if v else "default", z, a)
                for (v, z), a in results.items()))

    def test_cw_mirrors_ccw_without_ramp(self):
        ses = session(["joint_friction:torque_Nm=10.2,torque_per_N_m=0.0121"])
        ccw = deflection(ses, untilted_test("ccw"))
        cw = deflection(ses, untilted_test("cw"))
        n = ccw.shape[0]
        cw_at_ccw = cw[(n - np.arange(n)) % n]   # CW sample i is CCW sample (n − i) mod n
        self.assertGreater(np.max(np.abs(ccw)), 1e-4)
        np.testing.assert_allclose(cw_at_ccw, -ccw, atol=1e-9)

    def test_ramp_turns_the_force_linearly_over_the_travel(self):
        # [Joint patent] figs. 8 and 10: after a reversal the force changes linearly, then stays.
        n = 100
        travel = np.zeros((n, 6, 3))
        travel[:50, :, 0] = -0.1
        travel[50:, :, 0] = 0.1
        u = np.zeros((n, 6, 3))
        u[..., 2] = -1.0
        r = hp.ramp_states(travel, u, 2.0, literal=False, closed=False)
        self.assertAlmostEqual(r[49, 0, 0], -1.0)
        self.assertAlmostEqual(r[59, 0, 0], 0.0, places=12)   # half the ramp: 1 mm
        self.assertAlmostEqual(r[64, 0, 0], 0.5, places=12)
        self.assertAlmostEqual(r[69, 0, 0], 1.0, places=12)   # whole ramp: 2 mm
        self.assertEqual(r[79, 0, 0], 1.0)
        self.assertTrue(np.all(np.linalg.norm(r, axis=-1) <= 1.0 + 1e-12))
        np.testing.assert_allclose(hp.ramp_states(travel, u, 0.0, False, False),
                                   np.sign(travel), atol=0)

    def test_ramp_comes_from_the_commanded_motion_only(self):
        # The states depend on the commanded path alone: the deflections add up, with and
        # without gravity's own deflection (same compliance: the machine file's K_stiff2).
        spec = untilted_test()
        a = deflection(session(["joint_friction:ramp_mm=1.37"]), spec)
        b = deflection(session(["joint_friction:ramp_mm=1.37", "gravity_deflection"]), spec)
        g = deflection(session(["gravity_deflection"]), spec)
        np.testing.assert_allclose(b, a + g, atol=1e-12)


class Drift(unittest.TestCase):
    def test_uniform_growth_lowers_the_tip(self):
        x = hp.hole_centre(9, 1)[None, :]
        ang = np.zeros((1, 3))
        self.assertLess(tip_shift(np.full((1, 6), 0.01), x, ang)[0, 2], -0.01)

    def test_uniform_and_length_proportional_growth(self):
        spec = hp.jig_plan()[9]   # e_cw, tilted: the struts differ in length
        uniform = deflection(session(["thermal_drift:rate_um_per_h=8.37"]), spec)
        path, s = state(spec)
        hours = path.t / 3600.0
        np.testing.assert_allclose(uniform, 8.37e-3 * hours[:, None] * np.ones(6), rtol=1e-12)
        strain = deflection(session(["thermal_drift:strain_ppm_per_h=9.13"]), spec)
        ratio = strain / s.L
        np.testing.assert_allclose(ratio, 9.13e-6 * hours[:, None] * np.ones(6), rtol=1e-12)
        self.assertGreater(np.ptp(strain[-1]), 0.05 * np.mean(strain[-1]))  # not uniform

    def test_default_rate(self):
        eff = ht.resolve_effects([ht.parse_effect("thermal_drift")], MACHINE)
        self.assertEqual(eff["thermal_drift"], {"rate_um_per_h": 20.0, "strain_ppm_per_h": 0.0})


class ServoLag(unittest.TestCase):
    def test_radius_shrinks_by_c_v2_over_2r(self):
        # [Fujita thesis] eq. 2.1: the tool radius shrinks by c·V²/(2R).
        c_ms2 = 1000.0
        ses = session(["servo_lag:lag_coefficient_ms2=%g" % c_ms2])
        _, dr = ht.simulate_dbb(ses, untilted_test())
        v = hp.FEED_MM_MIN / 60.0
        expected_um = -1000.0 * c_ms2 * 1e-6 * v ** 2 / (2.0 * 150.0)
        self.assertAlmostEqual(np.mean(dr), expected_um, delta=0.05 * abs(expected_um))


class Noise(unittest.TestCase):
    def test_white_and_coloured_noise_have_the_size_asked_for(self):
        for model in ("white", "ar1"):
            ses = session(noise=0.3, noise_model=model)
            e = np.concatenate([ht.noise(ses, 720) for _ in range(30)])
            self.assertAlmostEqual(np.sqrt(np.mean(e ** 2)), 0.3, delta=0.02)
            lag1 = np.corrcoef(e[:-1], e[1:])[0, 1]
            if model == "white":
                self.assertLess(abs(lag1), 0.05)
            else:
                self.assertGreater(lag1, 0.9)


class Simulation(unittest.TestCase):
    def test_null_simulation_reads_the_bar_length(self):
        results = ht.simulate_session(session())
        self.assertEqual(len(results), 30)
        worst = max(np.max(np.abs(dr)) for _, _, dr in results)
        self.assertLess(worst, 1e-6)

    def test_controller_with_the_true_geometry_reads_the_bar_length(self):
        ses = session(perturb=(0.3, 0.1))
        ses.machine = hp.Machine(MACHINE.machine_id, ses.truth, MACHINE.gravity, MACHINE.friction)
        for spec in hp.jig_plan()[::7]:
            _, dr = ht.simulate_dbb(ses, spec)
            self.assertLess(np.max(np.abs(dr)), 1e-6)

    def test_platform_joint_error_is_outside_the_kinematic_model(self):
        ses = session(perturb=(0.3, 0.1), platform_mm=0.15)
        np.testing.assert_allclose(np.abs(ses.truth.platform - MACHINE.model.platform), 0.15,
                                   atol=1e-12)
        _, records = ht.simulate_session(ses, details=True)
        sizes = ht.effect_sizes(ses, records)
        self.assertGreater(sizes["platform_joint_error"]["rms_after_kinematics_um"], 1.0)

    def test_kinematic_parameters_absorb_a_strut_offset(self):
        # The effect sizes project out the 24 kinematic parameters: a uniform strut growth that
        # does not change with time (drift at t = 0 … a constant) is absorbed, a tool error not.
        ses = session(["tool_length_error:104.255=-47.3", "thermal_drift:rate_um_per_h=8.37"])
        _, records = ht.simulate_session(ses, details=True)
        sizes = ht.effect_sizes(ses, records)
        self.assertGreater(sizes["tool_length_error"]["rms_after_kinematics_um"], 1.0)
        self.assertLess(sizes["thermal_drift"]["rms_after_kinematics_um"],
                        0.5 * sizes["thermal_drift"]["rms_um"])

    def test_plan(self):
        plan = hp.jig_plan()
        self.assertEqual([f"{t.test_id}_{t.direction}" for t in plan[:3]],
                         ["a_ccw", "a_cw", "b_ccw"])
        self.assertEqual([t.start_s for t in plan[:3]], [0.0, 150.0, 300.0])
        by_id = {t.test_id: t for t in plan}
        np.testing.assert_allclose(by_id["g"].centre, [0.0, 100.0, -1050.0], atol=1e-12)
        self.assertEqual((by_id["g"].radius, by_id["g"].z_offset, by_id["g"].bar),
                         (144.0, 42.0, 150.0))
        self.assertEqual(by_id["h"].tool, 104.255)
        self.assertEqual(by_id["i"].tool, 150.0)

    def test_files_and_truth_written_in_time(self):
        with tempfile.TemporaryDirectory() as out:
            started = time.monotonic()
            rc = ht.main(["--out", out, "--seed", "3",
                          "--effect", "gravity_deflection:K_stiff2_mm_per_N=1.37e-5,"
                                      "platform_mass_kg=275,platform_cog_mm=30/-20/160",
                          "--effect", "joint_friction:torque_Nm=10.2,ramp_mm=1.37",
                          "--effect", "tool_length_error:104.255=-47.3",
                          "--effect", "thermal_drift:rate_um_per_h=8.37",
                          "--effect", "servo_lag", "--temperature", "--noise-model", "ar1"])
            elapsed = time.monotonic() - started
            self.assertEqual(rc, 0)
            self.assertLess(elapsed, 30.0)
            names = sorted(n for n in os.listdir(out) if n.endswith(".dbb"))
            self.assertEqual(len(names), 30)
            with open(os.path.join(out, "truth.json"), encoding="utf-8") as f:
                truth = json.load(f)
            self.assertEqual(truth["seed"], 3)
            self.assertEqual([e["effect"] for e in truth["effects"]],
                             ["gravity_deflection", "joint_friction", "tool_length_error",
                              "thermal_drift", "servo_lag"])
            self.assertEqual(truth["effects"][0]["parameters"]["platform_cog_mm"],
                             [30.0, -20.0, 160.0])
            self.assertEqual(truth["effects"][2]["parameters"],
                             {"error_um[104.255]": -47.3, "error_um[150]": 0.0})
            self.assertLess(truth["gravity_sign_check_tip_dz_um"], 0.0)
            self.assertEqual(set(truth["effect_size_um"]), {
                "gravity_deflection", "joint_friction", "tool_length_error", "thermal_drift",
                "servo_lag"})
            header, angles = read_dbb(os.path.join(out, "g_cw.dbb"))
            self.assertEqual(header["format"], "kinemetric-dbb/1")
            self.assertEqual(header["centre_mm"], "0, 100, -1050")
            self.assertEqual(header["fixed_ball_mm"], header["centre_mm"])
            self.assertEqual(header["tilt_deg"], "15, 0, 0")
            self.assertEqual(header["timestamp"], "2026-03-10T08:32:30Z")
            self.assertIn("temperature_c", header)
            self.assertEqual(len(angles), 720)
            self.assertEqual(angles[0], 0.0)
            self.assertTrue(np.all(np.diff(angles) < 0.0))
            self.assertAlmostEqual(angles[-1], -359.5)

    def test_partial_arcs_and_lead(self):
        with tempfile.TemporaryDirectory() as out:
            self.assertEqual(ht.main(["--out", out, "--arc-deg", "270", "--lead-mm", "10",
                                      "--no-sizes", "--effect", "joint_friction"]), 0)
            header, angles = read_dbb(os.path.join(out, "a_ccw.dbb"))
            self.assertEqual(header["arc_deg"], "270")
            lead_deg = np.degrees(10.0 / 150.0)
            self.assertAlmostEqual(angles[0], -lead_deg, places=5)
            self.assertAlmostEqual(angles[-1], 270.0 + lead_deg, places=5)
            self.assertLess(np.max(np.diff(angles)), 0.51)

    def test_unknown_effect_and_orphan_variant_are_refused(self):
        with self.assertRaises(ValueError):
            ht.parse_effect("backlash")
        with self.assertRaises(ValueError):
            session(variants=("friction_literal",))
        with self.assertRaises(ValueError):
            session(["joint_friction:ramp_mm=-1"])
        with self.assertRaises(ValueError):
            session(["gravity_deflection:platform_cog_mm=3"])


def read_dbb(path):
    header, angles = {}, []
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("#"):
                key, _, value = line[1:].partition(":")
                header[key.strip()] = value.strip()
            elif line[0].isdigit() or line[0] == "-":
                angles.append(float(line.split(",")[0]))
    return header, np.array(angles)


if __name__ == "__main__":
    unittest.main()
