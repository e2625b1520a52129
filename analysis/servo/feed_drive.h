// Friction of a serial feed drive from its motor force over strokes in both directions
// ([Fujita thesis] ch. 4, eqs. 4.1–4.2, 4.8; docs/methods.md §14).
//
// 1. Steady motion (the cruise of each stroke: at least half its own top speed, 2 mm past its
//    reversal): F = c0 + c1·x + f_rg(x) + F_c sign(v) + c_v v + m a, with the position-dependent
//    part f_rg(x) = (f₊ + f₋)/2 of eq. 4.8 (guide and screw waviness) written as sinusoids whose
//    periods are found from the periodogram of the binned residual and refined by Gauss–Newton
//    steps, and the direction-dependent part (f₊ − f₋)/2 = F_c + c_v |v| (Coulomb + viscous).
//    Weighted linear least squares (samples where the acceleration changes weigh less), σ from
//    the covariance widened by the strokes' disagreement and the slowest feed's pull.
// 2. Reversals: the LuGre model (eqs. 4.1–4.2), dz/dt = v − σ0 |v| z / g(v),
//    g(v) = F_c + (F_s − F_c) exp(−|v/v_s|^δ) or the Lorentzian F_c + (F_s − F_c)/(1 + (v/v_s)²)
//    (the whole analysis run with each, the better kept, σ covering both where they fit alike),
//    F = σ0 z + σ1 dz/dt + σ2 v, with F_c and σ2 from
//    step 1, integrated along the measured motion and fitted to the force less its
//    position-dependent part and inertia around every reversal; each parameter's σ includes the
//    ambiguity of the motion between samples, and a parameter the records do not determine is
//    declared so (LugreIdentifiable, lugre_note). Steady samples that feel the fitted Stribeck
//    rise get it taken out, and step 1 and 2 run once more.
// 3. Stick motion (quadrant glitch) on a circle of radius R at feed V with a position loop of
//    gain K_p: the presliding lost motion d = 2 F_c/σ0 is taken up by the loop while the
//    commanded axis moves d after its reversal, in t_d = √(2 d R)/V; the glitch is
//    h ≈ d / (1 + K_p t_d) (a first-order estimate, docs/methods.md §14).
#pragma once

#include <string>
#include <vector>

#include "analysis/servo/feed_drive_types.h"
#include "analysis/servo/servo_types.h"

namespace km::servo {

// One axis of a record (t_s from the file). Throws km::InvalidInput when the motion lacks
// strokes in both directions.
FeedDriveResult AnalyzeFeedDrive(const std::vector<double>& t_s, const AxisTrace& axis,
                                 const std::string& file, const FeedDriveOptions& options = {});

// Several records of the same axis analysed together (strokes at several feeds).
FeedDriveResult AnalyzeFeedDrive(const std::vector<const ServoFile*>& files,
                                 const std::string& axis, const FeedDriveOptions& options = {});

// Force of the LuGre model along a motion (x in mm, t in s), starting from z = 0.
std::vector<double> LugreForce(const LugreParameters& p, const std::vector<double>& t_s,
                               const std::vector<double>& x_mm);

double StickMotionUm(const LugreParameters& p, double radius_mm, double feed_mm_min,
                     double kp_per_s);

}  // namespace km::servo
