#!/usr/bin/python3
"""Unit checks of the truth simulator tests/sim/hexapod_truth.py (docs/hexapod-effects.md).

  /usr/bin/python3 tests/sim/test_hexapod_truth.py [-v]
"""

import json
import os
import sys
import tempfile
import time
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hexapod_truth as ht  # noqa: E402

MACHINE = ht.load_machine(ht.DEFAULT_MACHINE)
TOOL = ht.TOOLS_MM[0]


def session(effects=(), variants=(), perturb=(0.0, 0.0), noise=0.0, seed=1, samples=720):
    eff = ht.resolve_effects([ht.parse_effect(e) for e in effects], MACHINE)
    return ht.make_session(MACHINE, seed, noise, samples, perturb[0], perturb[1], eff, variants)


def untilted_test(direction="ccw", level=1):
    """Row-b-like test at the jig centre: untilted, radius 150, fixed ball at the centre."""
    return ht.DbbSpec("u", direction, ht.hole_centre(9, level), 150.0, 150.0, 0.0,
                       (0.0, 0.0, 0.0), TOOL, 0.0)


def deflection(ses, spec):
    """Σ Δs (N, 6) of the session's effects along the test's commanded path."""
    _, path = ht.commanded_path(spec, ses.samples)
    s = ht.strut_state(path.x, path.ang, MACHINE.model, spec.tool)
    return ht.effect_deflection(ses, s, path, spec, 0.0)


class Kinematics(unittest.TestCase):
    def test_rotation_derivatives_match_finite_differences(self):
        ang = np.radians(np.array([[12.0, -7.0, 30.0]]))
        h = 1e-7
        for k, analytic in enumerate(ht.rotation_derivatives(ang)):
            step = np.zeros(3)
            step[k] = h
            numeric = (ht.rotation(ang + step) - ht.rotation(ang - step)) / (2 * h)
            np.testing.assert_allclose(analytic, numeric, atol=1e-8)

    def test_rotation_order_is_rx_ry_rz(self):
        # [PM-600 report] eq. 1.4: a pure A tilt turns +y towards +z.
        r = ht.rotation(np.radians(np.array([[90.0, 0.0, 0.0]])))[0]
        np.testing.assert_allclose(r @ [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], atol=1e-15)
        a, b, c = np.radians([10.0, 20.0, 30.0])
        expected = ht._rx(np.array(a)) @ ht._ry(np.array(b)) @ ht._rz(np.array(c))
        np.testing.assert_allclose(ht.rotation(np.array([a, b, c])), expected, atol=1e-15)

    def test_ik_fk_round_trip(self):
        rng = np.random.default_rng(7)
        geom = ht.perturbed_geometry(MACHINE.model, rng, 0.3, 0.1)
        n = 500
        x = np.c_[rng.uniform(-200, 200, (n, 2)), rng.uniform(-1200, -900, n)]
        ang = np.radians(rng.uniform(-25, 25, (n, 3)))
        d = ht.strut_lengths(x, ang, geom, TOOL)
        x0 = x + rng.uniform(-1, 1, (n, 3))
        ang0 = ang + rng.uniform(-0.01, 0.01, (n, 3))
        xf, af = ht.forward_kinematics(d, x0, ang0, geom, TOOL)
        self.assertLess(np.max(np.abs(xf - x)), 1e-9)
        self.assertLess(np.max(np.abs(af - ang)) * 1000.0, 1e-9)  # 1 m lever
        self.assertLess(np.max(np.abs(ht.strut_lengths(xf, af, geom, TOOL) - d)), 1e-12)

    def test_longer_real_tool_moves_tip_along_minus_spindle_axis(self):
        # tool_length_error: error = real − programmed; at a fixed platform pose the tip moves
        # by −error along the spindle axis R·e_z.
        x = np.array([[30.0, -40.0, -1050.0]])
        ang = np.radians(np.array([[15.0, -10.0, 5.0]]))
        d = ht.strut_lengths(x, ang, MACHINE.model, TOOL)
        error = 0.062
        xf, af = ht.forward_kinematics(d, x, ang, MACHINE.model, TOOL + error)
        axis = ht.rotation(ang)[0] @ [0.0, 0.0, 1.0]
        np.testing.assert_allclose(xf[0], x[0] - error * axis, atol=1e-10)
        np.testing.assert_allclose(af, ang, atol=1e-14)


class Gravity(unittest.TestCase):
    def test_tool_sags_at_untilted_pose(self):
        for variants in ((), ("gravity_alt_mass",)):
            effects = ht.resolve_effects([("gravity_deflection", {})], MACHINE)
            dz_um = 1000.0 * ht.gravity_sign_check(MACHINE, effects, variants)[2]
            self.assertLess(dz_um, -1.0, variants)
            self.assertGreater(dz_um, -200.0, variants)

    def test_untilted_tensions_positive_and_carry_the_weights(self):
        for level in (1, 2, 3):
            x = ht.hole_centre(9, level)[None, :]
            s = ht.strut_state(x, np.zeros((1, 3)), MACHINE.model, TOOL)
            gm = ht.gravity_model(MACHINE)
            f = ht.gravity_forces(s, gm, TOOL)
            self.assertTrue(np.all(f.tension > 0.0), f.tension)
            self.assertTrue(np.all(f.axial < f.tension))  # the equivalent mass's share, eq. 3.5
            self.assertTrue(np.all(f.axial > 0.0))
            # Vertical components: Σ x_j l_jz = m_P g_z + Σ N_jz ([PM-600 report] eq. 3.4).
            lifted = -np.sum(f.tension * s.u[..., 2])
            platform = gm.m_platform * -gm.g[2]
            carried = -np.sum(f.carried[..., 2])
            self.assertAlmostEqual(lifted, platform + carried, delta=1e-9 * platform)
            # The carried share lies between nothing and the struts' whole carried weight.
            w = (gm.m_screw * (s.L - gm.l2 - gm.l3 / 2) + gm.m_joint * s.L
                 - gm.m_motor * gm.l1) / s.L
            self.assertGreater(carried, 0.0)
            self.assertLess(carried, np.sum(w) * -gm.g[2])
            # Moments balance about the tip.
            b_p = s.R[0] @ (gm.cog + [0.0, 0.0, TOOL])
            moment = np.sum(np.cross(s.B[0], f.tension[0][:, None] * s.u[0]), axis=0)
            expected = np.cross(b_p, gm.m_platform * gm.g) + \
                np.sum(np.cross(s.B[0], f.carried[0]), axis=0)
            np.testing.assert_allclose(moment, expected, atol=1e-6 * np.abs(expected).max())


class Friction(unittest.TestCase):
    def test_friction_flips_sign_between_cw_and_ccw(self):
        # A short ramp: away from the reversals every state is saturated and CW is exactly the
        # negative of CCW; with the 2 mm ramp the two still mirror each other closely.
        for ramp, share, corr_max in ((0.05, 0.7, -0.98), (2.0, 0.0, -0.9)):
            for variants in ((), ("friction_exponential",)):
                ses = session(["joint_friction:torque_Nm=8.88,ramp_mm=%g" % ramp], variants)
                ccw = deflection(ses, untilted_test("ccw"))
                cw = deflection(ses, untilted_test("cw"))
                n = ccw.shape[0]
                # Sample i of the CW test is the point of sample (n − i) mod n of the CCW test.
                cw_at_ccw = cw[(n - np.arange(n)) % n]
                self.assertGreater(np.max(np.abs(ccw)), 1e-3)  # > 1 µm
                opposite = np.all(np.abs(cw_at_ccw + ccw) < 1e-6 * np.max(np.abs(ccw)), axis=1)
                self.assertGreaterEqual(np.mean(opposite), share, (ramp, variants))
                corr = np.corrcoef(ccw.ravel(), cw_at_ccw.ravel())[0, 1]
                self.assertLess(corr, corr_max, (ramp, variants))

    def test_linear_ramp_reaches_the_other_side_over_the_ramp(self):
        # [Joint patent] fig. 11: after a reversal the state crosses from −1 to +1 over λ.
        delta = np.concatenate([-0.1 * np.ones(50), 0.1 * np.ones(50)])[:, None, None]
        r = ht.friction_states(np.broadcast_to(delta, (100, 6, 2)).copy(), ramp=2.0)
        self.assertEqual(r[49, 0, 0], -1.0)
        self.assertAlmostEqual(r[59, 0, 0], 0.0, places=12)   # half the ramp: 1 mm
        self.assertAlmostEqual(r[69, 0, 0], 1.0, places=12)   # whole ramp: 2 mm
        self.assertEqual(r[79, 0, 0], 1.0)


class Drift(unittest.TestCase):
    def test_uniform_growth_lowers_the_tip(self):
        x = ht.hole_centre(9, 1)[None, :]
        ang = np.zeros((1, 3))
        d = ht.strut_lengths(x, ang, MACHINE.model, TOOL) + 0.01
        xf, _ = ht.forward_kinematics(d, x, ang, MACHINE.model, TOOL)
        self.assertLess(xf[0, 2] - x[0, 2], -0.01)

    def test_step_drift_has_the_linear_total(self):
        ses = session(["thermal_drift:rate_um_per_h=20"], ("drift_step",))
        plan = ht.jig_plan()
        steps = ht.drift_steps(ses, plan)
        _, last = ht.commanded_path(plan[-1], ses.samples)
        self.assertEqual(steps[0], 0.0)
        self.assertAlmostEqual(steps[-1], last.t[-1], places=9)
        self.assertTrue(np.all(np.diff(steps) > 0.0))


class ServoLag(unittest.TestCase):
    def test_radius_shrinks_by_c_v2_over_2r(self):
        # [Fujita thesis] eq. 2.1: the tool radius shrinks by c·V²/(2R).
        c_ms2 = 1000.0
        ses = session(["servo_lag:lag_coefficient_ms2=%g" % c_ms2])
        _, dr, _ = ht.simulate_dbb(ses, untilted_test())
        v = ht.FEED_MM_MIN / 60.0
        expected_um = -1000.0 * c_ms2 * 1e-6 * v ** 2 / (2.0 * 150.0)
        self.assertAlmostEqual(np.mean(dr), expected_um, delta=0.05 * abs(expected_um))


class Simulation(unittest.TestCase):
    def test_null_simulation_reads_the_bar_length(self):
        results = ht.simulate_session(session())
        self.assertEqual(len(results), 30)
        worst = max(np.max(np.abs(dr)) for _, _, dr in results)
        self.assertLess(worst, 1e-6)

    def test_controller_with_the_true_geometry_reads_the_bar_length(self):
        # The same with a perturbed machine whose controller knows its geometry: the FK of the
        # perturbed struts lands on the commanded circle.
        ses = session(perturb=(0.3, 0.1))
        ses.machine = ht.Machine(MACHINE.machine_id, ses.truth, MACHINE.gravity, MACHINE.friction)
        for spec in ht.jig_plan()[::7]:
            _, dr, _ = ht.simulate_dbb(ses, spec)
            self.assertLess(np.max(np.abs(dr)), 1e-6)

    def test_plan(self):
        plan = ht.jig_plan()
        self.assertEqual([f"{t.test_id}_{t.direction}" for t in plan[:3]],
                         ["a_ccw", "a_cw", "b_ccw"])
        self.assertEqual([t.start_s for t in plan[:3]], [0.0, 150.0, 300.0])
        by_id = {t.test_id: t for t in plan}
        np.testing.assert_allclose(by_id["g"].centre, [0.0, 100.0, -1050.0], atol=1e-12)
        np.testing.assert_allclose(by_id["e"].centre, [70.710678119, 70.710678119, -1150.0])
        np.testing.assert_allclose(by_id["d"].centre, [70.710678119, -70.710678119, -1150.0])
        self.assertEqual((by_id["g"].radius, by_id["g"].z_offset, by_id["g"].bar),
                         (144.0, 42.0, 150.0))
        self.assertEqual(by_id["h"].tool, 104.255)
        self.assertEqual(by_id["i"].tool, 150.0)
        self.assertEqual(by_id["a"].tilt_deg, (20.0, 0.0, 0.0))
        self.assertEqual(by_id["o"].tilt_deg, (0.0, -20.0, 0.0))

    def test_files_and_truth_written_in_time(self):
        with tempfile.TemporaryDirectory() as out:
            started = time.monotonic()
            rc = ht.main(["--out", out, "--seed", "3", "--effect", "gravity_deflection",
                          "--effect", "joint_friction:torque_Nm=8.88,ramp_mm=2",
                          "--effect", "tool_length_error:104.255=-62",
                          "--effect", "thermal_drift:rate_um_per_h=20",
                          "--effect", "servo_lag", "--temperature"])
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
            self.assertEqual(truth["effects"][2]["parameters"],
                             {"error_um[104.255]": -62.0, "error_um[150]": 0.0})
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

    def test_unknown_effect_and_orphan_variant_are_refused(self):
        with self.assertRaises(ValueError):
            ht.parse_effect("backlash")
        with self.assertRaises(ValueError):
            session(variants=("drift_step",))
        with self.assertRaises(ValueError):
            session(["joint_friction:ramp_mm=0"])


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
