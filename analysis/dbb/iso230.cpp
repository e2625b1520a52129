#include "analysis/dbb/iso230.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <span>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "analysis/core/angles.h"
#include "analysis/core/errors.h"
#include "analysis/core/extremes.h"
#include "analysis/core/parallel.h"
#include "analysis/geometry/circle_fit.h"

namespace km::dbb {

namespace {

// Samples of a periodic function of the angle, sorted by angle in [0, 2π).
struct PeriodicTrace {
  std::vector<double> a;
  std::vector<double> v;
};

double WrapTurn(double angle_rad) {
  constexpr double kTurn = 2.0 * std::numbers::pi;
  // fmod leaves an angle already within [0, 2π) unchanged (it is exact); within one turn of that
  // range it subtracts or keeps exactly what the two shortcuts below give, without its loop.
  if (angle_rad >= 0.0 && angle_rad < kTurn) return angle_rad;
  if (angle_rad < 0.0 && angle_rad > -kTurn) return angle_rad + kTurn;
  if (angle_rad >= kTurn && angle_rad < 2.0 * kTurn) return angle_rad - kTurn;
  double t = std::fmod(angle_rad, kTurn);
  if (t < 0.0) t += kTurn;
  return t;
}

// A turn's sample order by angle in [0, 2π) when it does not depend on the values: `index`,
// with the angles `a` in that order; empty otherwise.
struct TurnOrder {
  std::vector<std::size_t> index;
  std::vector<double> a;
};

// One turn in time order is a rotation of the sorted order (reversed for cw, where most steps
// go down): rotated when that gives strictly increasing angles (then it is what sorting gives).
TurnOrder RotationOrder(const std::vector<double>& angle_rad) {
  const std::size_t n = angle_rad.size();
  TurnOrder o;
  if (n == 0) return o;
  std::vector<double> w(n);
  for (std::size_t i = 0; i < n; ++i) w[i] = WrapTurn(angle_rad[i]);
  std::size_t down = 0;
  for (std::size_t i = 1; i < n; ++i) down += w[i] < w[i - 1] ? 1 : 0;
  // Read in time order, or reversed for cw. The angles are a rotation of a strictly increasing
  // sequence exactly when one step (the closing one included) does not go up; the order then
  // starts after it, at the smallest angle (what rotating the sorted samples gives).
  const bool reversed = 2 * down > n;
  std::size_t flat = 0, start = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t next = i + 1 == n ? 0 : i + 1;
    // Step from sample i to the next one along the order (reversed: from next to i).
    const bool up = reversed ? w[i] > w[next] : w[next] > w[i];
    if (!up) {
      ++flat;
      start = reversed ? i : next;
    }
  }
  if (flat != 1) return o;
  o.index.resize(n);
  o.a.resize(n);
  for (std::size_t j = 0, i = start; j < n; ++j) {
    o.index[j] = i;
    o.a[j] = w[i];
    i = reversed ? (i == 0 ? n - 1 : i - 1) : (i + 1 == n ? 0 : i + 1);
  }
  return o;
}

// The samples sorted by angle in [0, 2π), sorted by angle, then value, keeping the first of
// equal angles (when the turn is not in rotation order: which sample is kept depends on values).
PeriodicTrace MakePeriodic(const std::vector<double>& angle_rad, std::span<const double> val) {
  PeriodicTrace p;
  std::vector<std::pair<double, double>> s(angle_rad.size());
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = {WrapTurn(angle_rad[i]), val[i]};
  std::sort(s.begin(), s.end());
  p.a.reserve(s.size());
  p.v.reserve(s.size());
  for (const auto& [t, v] : s) {
    if (!p.a.empty() && t <= p.a.back()) continue;  // duplicate angle: keep the first
    p.a.push_back(t);
    p.v.push_back(v);
  }
  return p;
}

// Where the angle t falls among the sorted periodic angles a (hi: the first angle > t): the two
// samples around it and the weight of the second.
struct Bracket {
  std::size_t i0, i1;
  double w;
};

Bracket PeriodicBracket(const std::vector<double>& a, std::size_t hi, double t) {
  const std::size_t n = a.size();
  const std::size_t i1 = hi == n ? 0 : hi;  // hi % n for hi in [0, n]
  const std::size_t i0 = hi == 0 ? n - 1 : hi - 1;
  double a0 = a[i0], a1 = a[i1];
  if (hi == 0) a0 -= 2.0 * std::numbers::pi;
  if (hi == n) a1 += 2.0 * std::numbers::pi;
  const double span = a1 - a0;
  return {i0, i1, span > 0.0 ? (t - a0) / span : 0.0};
}

// |q − the interpolated value|: one term of H (both ways of computing H use this).
double Gap(double q, double v0, double v1, double w) {
  return std::abs(q - (v0 * (1.0 - w) + v1 * w));
}

// Calls visit(i, bracket) for each of the sorted angles qa in the sorted periodic angles sa: one
// merge walk.
template <class Visit>
void WalkPeriodic(const std::vector<double>& qa, const std::vector<double>& sa, Visit&& visit) {
  std::size_t hi = 0;  // first src angle > query angle
  for (std::size_t i = 0; i < qa.size(); ++i) {
    const double t = qa[i];
    while (hi < sa.size() && sa[hi] <= t) ++hi;
    visit(i, PeriodicBracket(sa, hi, t));
  }
}

// max |q.v − src(q.a)| over the samples of q, with src interpolated periodically.
double MaxDifference(const PeriodicTrace& q, const PeriodicTrace& src) {
  double h = 0.0;
  WalkPeriodic(q.a, src.a, [&](std::size_t i, const Bracket& b) {
    h = std::max(h, Gap(q.v[i], src.v[b.i0], src.v[b.i1], b.w));
  });
  return h;
}

// The same walk for turns in rotation order, kept as sample indices in time order.
std::vector<Iso230PairGeometry::Interpolation> InterpolationTable(const TurnOrder& q,
                                                                  const TurnOrder& src) {
  std::vector<Iso230PairGeometry::Interpolation> t;
  t.reserve(q.a.size());
  WalkPeriodic(q.a, src.a, [&](std::size_t i, const Bracket& b) {
    t.push_back({static_cast<std::uint32_t>(q.index[i]),
                 static_cast<std::uint32_t>(src.index[b.i0]),
                 static_cast<std::uint32_t>(src.index[b.i1]), b.w});
  });
  return t;
}

// MaxDifference through a table: vq and vsrc in time order.
double MaxDifference(const std::vector<Iso230PairGeometry::Interpolation>& table,
                     std::span<const double> vq, std::span<const double> vsrc) {
  double h = 0.0;
  for (const auto& e : table) h = std::max(h, Gap(vq[e.q], vsrc[e.i0], vsrc[e.i1], e.w));
  return h;
}

// Samples of a trace over a partial arc, sorted by angle (radians) unwrapped about `mid`:
// t ↦ mid + wrap(t − mid) in [mid − π, mid + π).
PeriodicTrace MakeLinear(const std::vector<double>& angle_rad, std::span<const double> val,
                         double mid) {
  std::vector<std::pair<double, double>> s(angle_rad.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    double d = std::fmod(angle_rad[i] - mid + std::numbers::pi, 2.0 * std::numbers::pi);
    if (d < 0.0) d += 2.0 * std::numbers::pi;
    s[i] = {mid - std::numbers::pi + d, val[i]};
  }
  std::sort(s.begin(), s.end());
  PeriodicTrace p;
  for (const auto& [t, v] : s) {
    if (!p.a.empty() && t <= p.a.back()) continue;
    p.a.push_back(t);
    p.v.push_back(v);
  }
  return p;
}

// max |q.v − src(q.a)| over the samples of q inside src's range (linear interpolation, no wrap).
double MaxDifferenceOverlap(const PeriodicTrace& q, const PeriodicTrace& src) {
  double h = 0.0;
  if (src.a.size() < 2) return h;
  std::size_t hi = 0;
  for (std::size_t i = 0; i < q.a.size(); ++i) {
    const double t = q.a[i];
    if (t < src.a.front() || t > src.a.back()) continue;
    while (hi < src.a.size() && src.a[hi] < t) ++hi;
    if (hi == 0) {
      h = std::max(h, std::abs(q.v[i] - src.v[0]));
      continue;
    }
    const std::size_t i1 = std::min(hi, src.a.size() - 1), i0 = i1 - 1;
    const double span = src.a[i1] - src.a[i0];
    const double w = span > 0.0 ? (t - src.a[i0]) / span : 0.0;
    h = std::max(h, Gap(q.v[i], src.v[i0], src.v[i1], w));
  }
  return h;
}

std::vector<double> AnglesRad(const CircularTestResult& r) {
  std::vector<double> a(r.angle_deg.size());
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = r.angle_deg[i] * kDeg;
  return a;
}

// Common least-squares circle (centre x, y, radius) of the points (x, y): Gauss–Newton on the
// orthogonal distances started from `start` (the traces' own circles, µm from the common one:
// one or two steps reach machine precision).
Eigen::Vector3d CommonCircle(const Eigen::ArrayXd& x, const Eigen::ArrayXd& y,
                             const Eigen::Vector3d& start) {
  Eigen::Vector3d c = start;
  for (int it = 0; it < 8; ++it) {
    const geometry::CircleNormalEquations ne = geometry::CircleGaussNewton(x, y, c.head<2>(), c[2]);
    const Eigen::Vector3d step = -ne.jtj.ldlt().solve(ne.jtd);
    c += step;
    if (step.norm() < 1e-12 * c[2]) break;
  }
  return c;
}

// Radial deviations of both traces (cw, then ccw) about their common least-squares circle; sets
// the common centre and G(b) of `f`.
std::vector<double> CommonResiduals(const CircularTestResult& cw, const CircularTestResult& ccw,
                                    const std::vector<double>& dcw, const std::vector<double>& dccw,
                                    Iso230PairFigures& f) {
  const auto n = static_cast<Eigen::Index>(dcw.size() + dccw.size());
  Eigen::ArrayXd x(n), y(n);
  // Each trace in its planar representation (own nominal radius; equal for a proper pair).
  Eigen::Index k = 0;
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
  auto add = [&](const CircularTestResult& r, const std::vector<double>& d) {
    const double rt = NominalRadiusUm(r);
    for (std::size_t i = 0; i < d.size(); ++i, ++k) {
      const double rho = rt + d[i];
      x[k] = rho * CosAngle(r, i);
      y[k] = rho * SinAngle(r, i);
    }
    // The trace's own least-squares circle, weighted by its samples.
    const double w = static_cast<double>(d.size()) / static_cast<double>(n);
    start += w * Eigen::Vector3d(r.centre_offset_um[0], r.centre_offset_um[1],
                                 r.fitted_radius_mm * 1000.0);
  };
  add(cw, dcw);
  add(ccw, dccw);
  const Eigen::Vector3d c = CommonCircle(x, y, start);  // centre x, y, radius
  const Eigen::ArrayXd dist = ((x - c[0]).square() + (y - c[1]).square()).sqrt() - c[2];
  std::vector<double> res(dist.data(), dist.data() + n);
  f.common_centre_um = {c[0], c[1]};
  f.bidirectional_circular_deviation_um = dist.maxCoeff() - dist.minCoeff();
  return res;
}

// Radial deviation of a trace about its own least-squares centre, relative to the nominal
// radius: |P − c_own| − R = (R0 − R) + residual about the own circle.
std::vector<double> AboutOwnCentre(const CircularTestResult& r) {
  std::vector<double> v = r.radial_error_um;
  for (double& x : v) x += r.average_radial_error_um;
  return v;
}

// The checks of a pair (iso230.h).
void CheckPair(const CircularTestResult& cw, const CircularTestResult& ccw) {
  if (cw.direction != Direction::kCw || ccw.direction != Direction::kCcw) {
    throw InvalidInput("", 0, "direction", "a pair needs one cw and one ccw test");
  }
  if (cw.test_id != ccw.test_id) {
    throw InvalidInput("", 0, "test_id", "a pair needs the same test_id");
  }
  if (cw.units != ccw.units) {
    throw InvalidInput("", 0, "units", "the cw and ccw results are in different units");
  }
}

}  // namespace

double NominalRadiusUm(const CircularTestResult& r) {
  return r.fitted_radius_mm * 1000.0 - r.average_radial_error_um;
}

std::vector<double> DeviationAboutNominalCentre(const CircularTestResult& r) {
  const std::size_t n = r.angle_deg.size();
  const double r0 = r.fitted_radius_mm * 1000.0;
  const double rn = NominalRadiusUm(r);
  const double cx = r.centre_offset_um[0], cy = r.centre_offset_um[1];
  const double c2 = cx * cx + cy * cy;
  std::vector<double> dev(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double nc = CosAngle(r, i) * cx + SinAngle(r, i) * cy;
    const double q = r0 + r.radial_error_um[i];
    dev[i] = nc + std::sqrt(std::max(0.0, nc * nc - c2 + q * q)) - rn;
  }
  return dev;
}

Iso230Figures ComputeIso230(const CircularTestResult& r) {
  if (r.radial_error_um.empty()) throw InvalidInput("", 0, "dr_um", "empty trace");
  Iso230Figures f;
  f.units = r.units;
  f.full_turn = r.full_turn;
  f.evaluated_arc_deg = r.arc_deg;
  const auto [mn, mx] = Extremes(r.radial_error_um.data(), r.radial_error_um.size());
  f.circular_deviation_um = mx - mn;
  if (r.mode == Mode::kAbsolute) {
    const auto dev = DeviationAboutNominalCentre(r);
    const auto [dmn, dmx] = Extremes(dev.data(), dev.size());
    f.radial_deviation_max_um = dmx;
    f.radial_deviation_min_um = dmn;
    f.radial_reference = "nominal_centre";
  } else {
    f.radial_deviation_max_um = mx + r.average_radial_error_um;
    f.radial_deviation_min_um = mn + r.average_radial_error_um;
    f.radial_reference = "least_squares_centre";
  }
  return f;
}

Iso230PairFigures ComputeIso230Pair(const CircularTestResult& cw, const CircularTestResult& ccw) {
  return ComputeIso230Pair(cw, ccw, DeviationAboutNominalCentre(cw),
                           DeviationAboutNominalCentre(ccw));
}

Iso230PairGeometry::Iso230PairGeometry(const CircularTestResult& cw,
                                       const CircularTestResult& ccw) {
  CheckPair(cw, ccw);
  full_turn_ = cw.full_turn && ccw.full_turn;
  cw_rad_ = AnglesRad(cw);
  ccw_rad_ = AnglesRad(ccw);
  mid_rad_ = 0.5 * (ccw.turn_start_deg + ccw.turn_end_deg) * kDeg;
  if (!full_turn_) return;
  const TurnOrder ocw = RotationOrder(cw_rad_), occw = RotationOrder(ccw_rad_);
  if (ocw.index.empty() || occw.index.empty()) return;  // sorted at each call
  ccw_on_cw_ = InterpolationTable(occw, ocw);
  cw_on_ccw_ = InterpolationTable(ocw, occw);
}

double Iso230PairGeometry::Hysteresis(std::span<const double> vcw, std::span<const double> vccw,
                                      double* arc_deg) const {
  if (vcw.size() != cw_rad_.size() || vccw.size() != ccw_rad_.size()) {
    throw InvalidInput("", 0, "dr_um", "deviation and angle sizes differ");
  }
  if (full_turn_) {
    *arc_deg = 360.0;
    if (!ccw_on_cw_.empty()) {
      return std::max(MaxDifference(ccw_on_cw_, vccw, vcw), MaxDifference(cw_on_ccw_, vcw, vccw));
    }
    const PeriodicTrace pcw = MakePeriodic(cw_rad_, vcw);
    const PeriodicTrace pccw = MakePeriodic(ccw_rad_, vccw);
    return std::max(MaxDifference(pccw, pcw), MaxDifference(pcw, pccw));
  }
  const PeriodicTrace pcw = MakeLinear(cw_rad_, vcw, mid_rad_);
  const PeriodicTrace pccw = MakeLinear(ccw_rad_, vccw, mid_rad_);
  *arc_deg = std::max(
      0.0,
      (std::min(pcw.a.back(), pccw.a.back()) - std::max(pcw.a.front(), pccw.a.front())) / kDeg);
  if (*arc_deg <= 0.0) {
    throw InvalidInput("", 0, "angle_deg", "the cw and ccw arcs of the pair do not overlap");
  }
  return std::max(MaxDifferenceOverlap(pccw, pcw), MaxDifferenceOverlap(pcw, pccw));
}

namespace {

// The pair's figures with the geometry given, or built beside the common circle (`made`).
Iso230PairFigures PairFigures(const Iso230PairGeometry* given, const CircularTestResult& cw,
                              const CircularTestResult& ccw, const std::vector<double>& dcw,
                              const std::vector<double>& dccw, unsigned threads) {
  if (dcw.size() != cw.angle_deg.size() || dccw.size() != ccw.angle_deg.size()) {
    throw InvalidInput("", 0, "dr_um", "deviation and angle sizes differ");
  }
  CheckPair(cw, ccw);
  Iso230PairFigures f;
  f.units = ccw.units;
  // The common circle and the H about each own centre at once; then H about the common
  // centre (the ISO 230-4 figure, iso230.h) from the residuals and the shared angle order.
  std::vector<double> res;
  std::optional<Iso230PairGeometry> made;
  ParallelFor(
      2,
      [&](std::size_t k) {
        if (k == 0) {
          res = CommonResiduals(cw, ccw, dcw, dccw, f);
          return;
        }
        if (given == nullptr) made.emplace(cw, ccw);
        double arc = 0.0;
        f.circular_hysteresis_own_centres_um =
            (given ? *given : *made).Hysteresis(AboutOwnCentre(cw), AboutOwnCentre(ccw), &arc);
      },
      threads);
  const std::span<const double> all(res);
  f.circular_hysteresis_um =
      (given ? *given : *made)
          .Hysteresis(all.first(dcw.size()), all.subspan(dcw.size()), &f.evaluated_arc_deg);
  f.full_turn = cw.full_turn && ccw.full_turn;
  return f;
}

}  // namespace

Iso230PairFigures ComputeIso230Pair(const CircularTestResult& cw, const CircularTestResult& ccw,
                                    const std::vector<double>& dcw, const std::vector<double>& dccw,
                                    unsigned threads) {
  return PairFigures(nullptr, cw, ccw, dcw, dccw, threads);
}

Iso230PairFigures ComputeIso230Pair(const Iso230PairGeometry& geometry,
                                    const CircularTestResult& cw, const CircularTestResult& ccw,
                                    const std::vector<double>& dcw,
                                    const std::vector<double>& dccw) {
  return PairFigures(&geometry, cw, ccw, dcw, dccw, 1);
}

}  // namespace km::dbb
