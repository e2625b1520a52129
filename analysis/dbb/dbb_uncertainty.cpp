#include "analysis/dbb/dbb_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <span>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/dbb/iso230.h"
#include "analysis/geometry/circle_fit.h"
#include "analysis/geometry/min_zone_circle.h"

namespace km::dbb {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The normal equations of one Gauss–Newton step of the orthogonal-distance circle fit
// (geometry::CircleGaussNewton's, circle_fit.h) in one pass without temporaries.
geometry::CircleNormalEquations NormalEquations(const Eigen::ArrayXd& x, const Eigen::ArrayXd& y,
                                                const Vector3d& c) {
  double sxx = 0, sxy = 0, syy = 0, sx = 0, sy = 0, n = 0, bx = 0, by = 0, b = 0;
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    const double vx = x[k] - c[0], vy = y[k] - c[1];
    const double dist = std::sqrt(vx * vx + vy * vy);
    if (!(dist > 0.0)) continue;
    const double ux = vx / dist, uy = vy / dist, d = dist - c[2];
    sxx += ux * ux;
    sxy += ux * uy;
    syy += uy * uy;
    sx += ux;
    sy += uy;
    n += 1.0;
    bx -= ux * d;
    by -= uy * d;
    b -= d;
  }
  geometry::CircleNormalEquations ne;
  ne.jtj << sxx, sxy, sx, sxy, syy, sy, sx, sy, n;
  ne.jtd << bx, by, b;
  return ne;
}

// The least-squares circle (centre x, y, radius) of the points (x, y): Gauss–Newton on the
// orthogonal distances from `c`, the unperturbed circle a fraction of a micrometre away, until a
// step is below 1e-12 of the radius (as iso230.cpp's common circle).
Vector3d LeastSquaresCircleFrom(const Eigen::ArrayXd& x, const Eigen::ArrayXd& y, Vector3d c) {
  for (int it = 0; it < 30; ++it) {
    const geometry::CircleNormalEquations ne = NormalEquations(x, y, c);
    const Vector3d step = -ne.jtj.ldlt().solve(ne.jtd);
    c += step;
    if (step.norm() <= 1e-12 * c[2]) return c;
  }
  throw DidNotConverge("uncertainty: the least-squares circle of a draw did not converge");
}

// The minimum zone of points that differ from known ones by radial changes Δ_k, exactly: the
// zone of the points near the known zone's circles (and a few spread around), then every point
// checked against it; points outside are added and the zone solved again. The zone of a subset
// is never wider than that of all points, and one that holds every point is theirs.
class WarmMinZone {
 public:
  void Init(const std::vector<Vector2d>& pts, const Vector2d& centre, double band_um) {
    centre_ = centre;
    band_ = band_um;
    d0_.resize(pts.size());
    for (std::size_t k = 0; k < pts.size(); ++k) d0_[k] = (pts[k] - centre).norm();
    in_.assign(pts.size(), 0);
    const std::size_t step = std::max<std::size_t>(1, pts.size() / 16);
    skeleton_.clear();
    for (std::size_t k = 0; k < pts.size(); k += step) skeleton_.push_back(k);
  }

  // Width of the zone of `pts` (µm); `shift` the radial change of each point since Init.
  double Width(const std::vector<Vector2d>& pts, std::span<const double> shift) {
    const std::size_t n = pts.size();
    double hi = -std::numeric_limits<double>::infinity(), lo = -hi;
    for (std::size_t k = 0; k < n; ++k) {
      const double v = d0_[k] + shift[k];
      hi = std::max(hi, v);
      lo = std::min(lo, v);
    }
    cand_.clear();
    for (std::size_t k : skeleton_) Add(k);
    for (std::size_t k = 0; k < n; ++k) {
      const double v = d0_[k] + shift[k];
      if (v >= hi - band_ || v <= lo + band_) Add(k);
    }
    double width = 0.0;
    for (int round = 0; round < 50; ++round) {
      sub_.resize(cand_.size());
      for (std::size_t j = 0; j < cand_.size(); ++j) sub_[j] = pts[cand_[j]];
      const geometry::MinZoneCircleResult z = geometry::FitMinZoneCircle(sub_, centre_);
      width = z.width;
      const double tol = 1e-7;
      const std::size_t before = cand_.size();
      for (std::size_t k = 0; k < n; ++k) {
        if (in_[k]) continue;
        const double d = (pts[k] - z.centre).norm();
        if (d > z.outer_radius + tol || d < z.inner_radius - tol) Add(k);
      }
      if (cand_.size() == before) break;
    }
    for (std::size_t k : cand_) in_[k] = 0;
    return width;
  }

 private:
  void Add(std::size_t k) {
    if (in_[k]) return;
    in_[k] = 1;
    cand_.push_back(k);
  }
  Vector2d centre_ = Vector2d::Zero();
  double band_ = 0.0;
  std::vector<double> d0_;
  std::vector<char> in_;
  std::vector<std::size_t> skeleton_, cand_;
  std::vector<Vector2d> sub_;
};

// One test's figures for a draw: the tool-path deviations of the evaluated turn plus
// f·(u_r·z_k + c), c the shared bar error (µm of bar).
class TestModel {
 public:
  void Init(const DbbTestReport& rep, double u_reading) {
    base_ = &rep.circular;
    r_ = rep.circular;
    dev0_ = DeviationAboutNominalCentre(rep.circular);
    n_ = dev0_.size();
    rn_ = NominalRadiusUm(rep.circular);
    f_ = rep.circular.deviation_factor;
    u_ = u_reading;
    circle0_ = Vector3d(r_.centre_offset_um[0], r_.centre_offset_um[1], r_.fitted_radius_mm * 1e3);
    dev_.resize(n_);
    shift_.resize(n_);
    x_.resize(static_cast<Eigen::Index>(n_));
    y_.resize(static_cast<Eigen::Index>(n_));
    pts_.resize(n_);
    Fill(std::span<const double>(), 0.0);
    // Band of the candidates of the minimum zone: the zone's centre moves about as much as its
    // contact readings do; the check against every point makes it exact whatever the band.
    mz_.Init(pts_, rep.min_zone.centre, f_ * u_ + 1e-3);
  }

  std::size_t size() const { return n_; }
  const CircularTestResult& result() const { return r_; }
  const std::vector<double>& deviations() const { return dev_; }
  const std::vector<Vector2d>& points() const { return pts_; }
  double factor() const { return f_; }
  double reading_u() const { return u_; }
  WarmMinZone& min_zone() { return mz_; }

  // y[0..3]: circularity, G, minimum zone, average radial error. z: n standard normals (empty:
  // none), c: the shared bar error in µm.
  void Evaluate(std::span<const double> z, double c, std::span<double> y) {
    Fill(z, c);
    const Vector3d circle = LeastSquaresCircleFrom(x_, y_, circle0_);
    r_.centre_offset_um = {circle[0], circle[1]};
    r_.fitted_radius_mm = circle[2] / 1e3;
    r_.average_radial_error_um = circle[2] - rn_;
    double mn = std::numeric_limits<double>::infinity(), mx = -mn;
    for (std::size_t k = 0; k < n_; ++k) {
      const auto i = static_cast<Eigen::Index>(k);
      const double dx = x_[i] - circle[0], dy = y_[i] - circle[1];
      const double e = std::sqrt(dx * dx + dy * dy) - circle[2];
      r_.radial_error_um[k] = e;
      mn = std::min(mn, e);
      mx = std::max(mx, e);
    }
    r_.circularity_um = mx - mn;  // circular_test.cpp: eq. 4.8, the range about the fit
    y[0] = r_.circularity_um;
    y[1] = ComputeIso230(r_).circular_deviation_um;
    y[2] = mz_.Width(pts_, shift_);
    y[3] = r_.average_radial_error_um;
  }

 private:
  void Fill(std::span<const double> z, double c) {
    for (std::size_t k = 0; k < n_; ++k) {
      const double d = f_ * ((z.empty() ? 0.0 : u_ * z[k]) + c);
      shift_[k] = d;
      dev_[k] = dev0_[k] + d;
      const double rho = rn_ + dev_[k];
      const auto i = static_cast<Eigen::Index>(k);
      x_[i] = rho * CosAngle(*base_, k);
      y_[i] = rho * SinAngle(*base_, k);
      pts_[k] = Vector2d(x_[i], y_[i]);
    }
  }

  const CircularTestResult* base_ = nullptr;
  CircularTestResult r_;
  std::vector<double> dev0_, dev_, shift_;
  std::size_t n_ = 0;
  double rn_ = 0.0, f_ = 1.0, u_ = 0.0;
  Vector3d circle0_ = Vector3d::Zero();
  Eigen::ArrayXd x_, y_;
  std::vector<Vector2d> pts_;
  WarmMinZone mz_;
};

// The shared bar error of a draw in µm of bar: δL + α·L·δT (α in ppm/K, L in mm, δT in K).
double SharedBarError(std::span<const double> x, std::size_t at, double alpha_l) {
  return x[at] + alpha_l * x[at + 1];
}

// First-order standard deviation of a linear function g·e of independent readings e_k of
// standard deviations s_k; g from a least-squares circle of points (x, y) about circle c: for
// the radius R0 (which == −1) or for the range res_M − res_m of the residuals.
double LeastSquaresFirstOrder(const Eigen::ArrayXd& x, const Eigen::ArrayXd& y, const Vector3d& c,
                              const std::vector<double>& s, long which_max, long which_min) {
  const geometry::CircleNormalEquations ne = geometry::CircleGaussNewton(x, y, c.head<2>(), c[2]);
  const Eigen::Matrix3d inv = ne.jtj.inverse();
  const auto row = [&](Eigen::Index k) {
    const double dx = x[k] - c[0], dy = y[k] - c[1], d = std::sqrt(dx * dx + dy * dy);
    return Vector3d(-dx / d, -dy / d, -1.0);
  };
  // δθ = −inv·Jᵀ·δd; δres_k = δd_k + J_k·δθ.
  Vector3d v = Vector3d::Zero();
  if (which_max < 0) {
    v = -inv.row(2).transpose();  // δR0 = Σ_k (−inv·J_kᵀ)_2 δd_k
  } else {
    v = inv * (row(which_max) - row(which_min));
  }
  double var = 0.0;
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    double g = which_max < 0 ? v.dot(row(k)) : -row(k).dot(v);
    if (k == which_max) g += 1.0;
    if (k == which_min) g -= 1.0;
    var += s[static_cast<std::size_t>(k)] * s[static_cast<std::size_t>(k)] * g * g;
  }
  return std::sqrt(var);
}

// First-order σ of the minimum zone from the reading group: central differences of the zone on
// its contact readings (the others lie strictly inside and do not move it to first order).
// NaN when the zone touches more than 16 readings (a zone that is not differentiable there).
double MinZoneFirstOrder(TestModel& m, const DbbTestReport& rep) {
  if (!(m.reading_u() > 0.0)) return 0.0;
  const auto& z = rep.min_zone;
  std::vector<std::size_t> contacts;
  for (std::size_t k = 0; k < m.size(); ++k) {
    const double d = (m.points()[k] - z.centre).norm();
    if (d >= z.outer_radius - 1e-6 || d <= z.inner_radius + 1e-6) contacts.push_back(k);
  }
  if (contacts.size() > 16) return kNaN;
  std::vector<double> shift(m.size(), 0.0);
  std::vector<Vector2d> pts = m.points();
  const double h = 1e-3;  // µm of tool path
  double var = 0.0;
  for (std::size_t k : contacts) {
    const Vector2d unit = pts[k].normalized();
    double w[2];
    for (int s = 0; s < 2; ++s) {
      const double dh = s == 0 ? h : -h;
      shift[k] = dh;
      pts[k] = m.points()[k] + dh * unit;
      w[s] = m.min_zone().Width(pts, shift);
    }
    shift[k] = 0.0;
    pts[k] = m.points()[k];
    const double g = (w[0] - w[1]) / (2.0 * h) * m.factor() * m.reading_u();
    var += g * g;
  }
  return std::sqrt(var);
}

// Index of the largest and of the smallest value.
std::pair<long, long> ArgMaxMin(const std::vector<double>& v) {
  const auto [mn, mx] = std::minmax_element(v.begin(), v.end());
  return {static_cast<long>(mx - v.begin()), static_cast<long>(mn - v.begin())};
}

// The reading group's first-order σ of a test's four figures (NaN where none).
std::array<double, 4> TestGroupFirstOrder(TestModel& m, const DbbTestReport& rep) {
  const std::size_t n = m.size();
  Eigen::ArrayXd x(static_cast<Eigen::Index>(n)), y(static_cast<Eigen::Index>(n));
  for (std::size_t k = 0; k < n; ++k) {
    x[static_cast<Eigen::Index>(k)] = m.points()[k].x();
    y[static_cast<Eigen::Index>(k)] = m.points()[k].y();
  }
  const auto& r = rep.circular;
  const Vector3d c(r.centre_offset_um[0], r.centre_offset_um[1], r.fitted_radius_mm * 1e3);
  const std::vector<double> s(n, m.factor() * m.reading_u());
  const auto [imax, imin] = ArgMaxMin(r.radial_error_um);
  const double range = LeastSquaresFirstOrder(x, y, c, s, imax, imin);
  return {range, range, MinZoneFirstOrder(m, rep), LeastSquaresFirstOrder(x, y, c, s, -1, -1)};
}

// The reading group's first-order σ of G(b): the range of both traces' residuals about their
// common least-squares circle.
double BidirectionalFirstOrder(TestModel& a, TestModel& b, const DbbPairReport& pair) {
  const std::size_t n = a.size() + b.size();
  Eigen::ArrayXd x(static_cast<Eigen::Index>(n)), y(static_cast<Eigen::Index>(n));
  std::vector<double> s(n);
  std::size_t k = 0;
  for (TestModel* m : {&a, &b}) {
    for (std::size_t i = 0; i < m->size(); ++i, ++k) {
      x[static_cast<Eigen::Index>(k)] = m->points()[i].x();
      y[static_cast<Eigen::Index>(k)] = m->points()[i].y();
      s[k] = m->factor() * m->reading_u();
    }
  }
  const Vector2d centre(pair.iso230_4.common_centre_um[0], pair.iso230_4.common_centre_um[1]);
  const Eigen::ArrayXd d = ((x - centre.x()).square() + (y - centre.y()).square()).sqrt();
  const double radius = d.mean();  // ∂/∂r of the sum of squares is zero at the fit
  std::vector<double> res(d.data(), d.data() + d.size());
  const auto [imax, imin] = ArgMaxMin(res);
  return LeastSquaresFirstOrder(x, y, Vector3d(centre.x(), centre.y(), radius), s, imax, imin);
}

std::vector<uncertainty::McInput> Inputs(std::size_t readings, double u_reading,
                                         const DbbInputUncertainty& shared) {
  using uncertainty::McInput;
  // The readings as standard normals: each test's model scales them by its own u_reading_um.
  return {McInput::NormalGroup(kDbbInputNames[0], 0.0, u_reading > 0.0 ? 1.0 : 0.0, readings),
          McInput::Normal(kDbbInputNames[1], 0.0, shared.bar_length_um),
          McInput::Normal(kDbbInputNames[2], 0.0,
                          shared.expansion_ppm_per_k > 0.0 ? shared.bar_temperature_c : 0.0)};
}

uncertainty::McOptions McOptionsOf(const DbbUncertaintyOptions& o) {
  uncertainty::McOptions mo;
  mo.draws = o.draws;
  mo.seed = o.seed;
  mo.budget_draws = o.budget_draws;
  return mo;
}

// The GUM check: the shared inputs by central differences of the same model (the readings at
// their estimate 0), the reading group's first-order σ given (`group`, NaN: none), combined in
// quadrature and set beside the Monte Carlo u.
std::vector<uncertainty::GumCheck> GumCheck(const uncertainty::VectorModel& model,
                                            const std::vector<uncertainty::McInput>& inputs,
                                            const uncertainty::McResult& mc,
                                            const std::vector<std::string>& keys,
                                            const std::vector<double>& group) {
  const std::size_t ng = inputs[0].count;
  const std::vector<uncertainty::McInput> shared(inputs.begin() + 1, inputs.end());
  std::vector<double> full(ng + shared.size(), 0.0);
  const uncertainty::VectorModel sub = [&](std::span<const double> x, std::span<double> y) {
    std::copy(x.begin(), x.end(), full.begin() + static_cast<std::ptrdiff_t>(ng));
    model(full, y);
  };
  const std::vector<double> u_shared =
      uncertainty::FirstOrderUncertainties(sub, shared, keys.size());
  std::vector<uncertainty::GumCheck> out;
  for (std::size_t j = 0; j < keys.size(); ++j) {
    uncertainty::GumCheck c{keys[j], std::hypot(u_shared[j], group[j]), mc.outputs[j].u, 0.0,
                            false};
    if (std::isnan(c.u_gum)) {
      c.relative_difference = kNaN;
    } else {
      const double d = std::abs(c.u_gum - c.u_mc);
      c.relative_difference = c.u_mc > 0.0 ? d / c.u_mc : (d > 1e-12 ? HUGE_VAL : 0.0);
      c.differs = c.relative_difference > 0.05;
    }
    out.push_back(c);
  }
  return out;
}

std::string Text(const char* format, double a, double b) {
  char buf[256];
  std::snprintf(buf, sizeof buf, format, a, b);
  return buf;
}

}  // namespace

DbbUncertainty PropagateDbbTest(const DbbTest& test, const DbbTestReport& report,
                                const DbbInputUncertainty& u,
                                const DbbUncertaintyOptions& options) {
  TestModel m;
  m.Init(report, u.reading_um);
  const std::size_t n = m.size();
  const double alpha_l = u.expansion_ppm_per_k * test.bar_length_mm * 1e-3;  // µm per K
  const auto inputs = Inputs(n, u.reading_um, u);
  const uncertainty::VectorModel model = [&](std::span<const double> x, std::span<double> y) {
    m.Evaluate(x.first(n), SharedBarError(x, n, alpha_l), y);
  };
  DbbUncertainty out;
  out.figure_keys.assign(kDbbTestFigureKeys.begin(), kDbbTestFigureKeys.end());
  std::array<double, 4> group{};
  if (options.gum_check && u.reading_um > 0.0) group = TestGroupFirstOrder(m, report);
  out.mc = uncertainty::PropagateMonteCarlo(model, inputs, 4, McOptionsOf(options));
  if (options.gum_check) {
    out.gum = GumCheck(model, inputs, out.mc, out.figure_keys, {group.begin(), group.end()});
  }
  if (u.reading_um > 0.0) {
    out.notes.push_back(
        Text("u_reading_um: drawn independently for each of the %.0f readings "
             "of the evaluated turn (%.0f values a draw)",
             static_cast<double>(n), static_cast<double>(n)));
  }
  if (std::isnan(group[2])) {
    out.notes.push_back(
        "min_zone_circularity_um: no first-order value for the readings: the zone touches more "
        "than 16 of them (not differentiable there)");
  }
  return out;
}

DbbUncertainty PropagateDbbPair(const DbbTest& cw, const DbbTest& ccw, const DbbTestReport& rcw,
                                const DbbTestReport& rccw, const DbbPairReport& pair,
                                const DbbInputUncertainty& ucw, const DbbInputUncertainty& uccw,
                                const DbbUncertaintyOptions& options) {
  DbbUncertainty out;
  DbbInputUncertainty shared = ucw;
  shared.bar_length_um = std::max(ucw.bar_length_um, uccw.bar_length_um);
  shared.bar_temperature_c = std::max(ucw.bar_temperature_c, uccw.bar_temperature_c);
  shared.expansion_ppm_per_k = std::max(ucw.expansion_ppm_per_k, uccw.expansion_ppm_per_k);
  if (ucw.bar_length_um != uccw.bar_length_um || ucw.bar_temperature_c != uccw.bar_temperature_c ||
      ucw.expansion_ppm_per_k != uccw.expansion_ppm_per_k) {
    out.notes.push_back(
        "the cw and ccw files state different bar uncertainties; one bar serves both: the larger "
        "of each is drawn once for both tests");
  }
  TestModel a, b;
  a.Init(rcw, ucw.reading_um);
  b.Init(rccw, uccw.reading_um);
  const std::size_t na = a.size(), nb = b.size();
  const double alpha_l = shared.expansion_ppm_per_k * cw.bar_length_mm * 1e-3;
  const auto inputs = Inputs(na + nb, std::max(ucw.reading_um, uccw.reading_um), shared);
  const uncertainty::VectorModel model = [&](std::span<const double> x, std::span<double> y) {
    const double c = SharedBarError(x, na + nb, alpha_l);
    a.Evaluate(x.first(na), c, y.first(4));
    b.Evaluate(x.subspan(na, nb), c, y.subspan(4, 4));
    const Iso230PairFigures p =
        ComputeIso230Pair(a.result(), b.result(), a.deviations(), b.deviations(), 1);
    y[8] = p.circular_hysteresis_um;
    y[9] = p.bidirectional_circular_deviation_um;
  };
  for (const char* k : kDbbTestFigureKeys) out.figure_keys.push_back(std::string("cw.") + k);
  for (const char* k : kDbbTestFigureKeys) out.figure_keys.push_back(std::string("ccw.") + k);
  for (const char* k : kDbbPairFigureKeys) out.figure_keys.push_back(k);
  std::vector<double> group(10, 0.0);
  const bool readings = ucw.reading_um > 0.0 || uccw.reading_um > 0.0;
  if (options.gum_check && readings) {
    const auto ga = TestGroupFirstOrder(a, rcw);
    const auto gb = TestGroupFirstOrder(b, rccw);
    std::copy(ga.begin(), ga.end(), group.begin());
    std::copy(gb.begin(), gb.end(), group.begin() + 4);
    group[8] = kNaN;
    group[9] = BidirectionalFirstOrder(a, b, pair);
    out.notes.push_back(
        "circular_hysteresis_um: no first-order value for the readings (the largest difference "
        "of two interpolated traces); Monte Carlo alone");
  }
  (void)ccw;
  out.mc = uncertainty::PropagateMonteCarlo(model, inputs, 10, McOptionsOf(options));
  if (options.gum_check) out.gum = GumCheck(model, inputs, out.mc, out.figure_keys, group);
  if (readings) {
    out.notes.push_back(
        Text("u_reading_um: drawn independently for each of the %.0f + %.0f "
             "readings of the two evaluated turns",
             static_cast<double>(na), static_cast<double>(nb)));
  }
  return out;
}

}  // namespace km::dbb
