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
#include "analysis/core/option_check.h"
#include "analysis/dbb/iso230.h"
#include "analysis/geometry/circle_fit.h"
#include "analysis/geometry/circle_fit_radial.h"
#include "analysis/geometry/min_zone_circle.h"
#include "analysis/geometry/min_zone_radial.h"

namespace km::dbb {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

// The draw's models (named: DbbPairModel::Impl holds them).
namespace mc_model {

// One test's figures for a draw: the tool-path deviations of the evaluated turn plus
// s_k = f·(u_r·z_k + c), c the shared bar error (µm of bar). The readings move along their
// angles only, so the least-squares circle is the base fit's linearisation
// (geometry/circle_fit_radial.h) and the minimum zone a warm start from the base zone that is
// checked against every point (geometry/min_zone_radial.h).
class TestModel {
 public:
  void Init(const DbbTestReport& rep, double u_reading) {
    const CircularTestResult& r = rep.circular;
    const std::vector<double> dev0 = DeviationAboutNominalCentre(r);
    n_ = dev0.size();
    rn_ = NominalRadiusUm(r);
    f_ = r.deviation_factor;
    u_ = u_reading;
    for (auto* v : {&x0_, &y0_, &cos_, &sin_}) v->resize(n_);
    pts_.resize(n_);
    for (std::size_t k = 0; k < n_; ++k) {
      cos_[k] = CosAngle(r, k);
      sin_[k] = SinAngle(r, k);
      const double rho = rn_ + (dev0[k] + 0.0);
      x0_[k] = rho * cos_[k];
      y0_[k] = rho * sin_[k];
      pts_[k] = Vector2d(x0_[k], y0_[k]);
    }
    fit_.Init(x0_, y0_, cos_, sin_,
              Vector3d(r.centre_offset_um[0], r.centre_offset_um[1], r.fitted_radius_mm * 1e3));
    // Band of the candidates of the minimum zone: the zone's centre moves about as much as its
    // contact readings do; the check against every point makes it exact whatever the band.
    mz_.Init(x0_, y0_, cos_, sin_, rep.min_zone.centre, f_ * u_ + 1e-3);
  }

  std::size_t size() const { return n_; }
  const std::vector<Vector2d>& points() const { return pts_; }  // the unperturbed points
  std::span<const double> x0() const { return x0_; }
  std::span<const double> y0() const { return y0_; }
  std::span<const double> cos() const { return cos_; }
  std::span<const double> sin() const { return sin_; }
  const Vector3d& circle() const { return fit_.base(); }
  double factor() const { return f_; }
  double reading_u() const { return u_; }
  geometry::RadialMinZone& min_zone() { return mz_; }

  // The moves of a draw into s: z n standard normals (empty: none), c the shared bar error.
  void Shift(std::span<const double> z, double c, std::span<double> s) const {
    if (z.empty()) {
      std::fill(s.begin(), s.end(), f_ * (0.0 + c));
      return;
    }
    for (std::size_t k = 0; k < n_; ++k) s[k] = f_ * (u_ * z[k] + c);
  }

  // y[0..3]: circularity, G, minimum zone, average radial error, for the moves s.
  void Evaluate(std::span<const double> s, std::span<double> y) {
    const geometry::RadialCircleFit::Result fit = fit_.Fit(s, {});
    y[0] = fit.max - fit.min;  // circular_test.cpp: eq. 4.8, the range about the fit
    y[1] = y[0];               // ComputeIso230: G, the range of the same residuals (iso230.h)
    y[2] = mz_.Width(s);
    y[3] = fit.circle[2] - rn_;
  }

 private:
  std::size_t n_ = 0;
  double rn_ = 0.0, f_ = 1.0, u_ = 0.0;
  std::vector<double> x0_, y0_, cos_, sin_;
  std::vector<Vector2d> pts_;
  geometry::RadialCircleFit fit_;
  geometry::RadialMinZone mz_;
};

// A pair's H and G(b) for a draw: both traces' moves s (cw, then ccw), their common circle
// linearised as each test's own (geometry/circle_fit_radial.h), H through the pair's geometry
// built once (iso230.h: the angles do not change between draws).
class PairModel {
 public:
  PairModel(const CircularTestResult& rcw, const CircularTestResult& rccw, const TestModel& a,
            const TestModel& b)
      : geometry_(rcw, rccw) {
    std::vector<double> x, y, c, s;
    for (const TestModel* m : {&a, &b}) {
      x.insert(x.end(), m->x0().begin(), m->x0().end());
      y.insert(y.end(), m->y0().begin(), m->y0().end());
      c.insert(c.end(), m->cos().begin(), m->cos().end());
      s.insert(s.end(), m->sin().begin(), m->sin().end());
    }
    // Started from the traces' own circles weighted by their samples (as ComputeIso230Pair).
    const double n = static_cast<double>(x.size());
    const Vector3d start = static_cast<double>(a.size()) / n * a.circle() +
                           static_cast<double>(b.size()) / n * b.circle();
    common_.Init(x, y, c, s, start);
    na_ = a.size();
    res_.resize(x.size());
  }

  // y[0]: H, y[1]: G(b) for the moves s of both traces.
  void Evaluate(std::span<const double> s, std::span<double> y) {
    const geometry::RadialCircleFit::Result fit = common_.Fit(s, res_);
    const std::span<const double> res(res_);
    double arc = 0.0;
    y[0] = geometry_.Hysteresis(res.first(na_), res.subspan(na_), &arc);
    y[1] = fit.max - fit.min;
  }

 private:
  Iso230PairGeometry geometry_;
  geometry::RadialCircleFit common_;
  std::size_t na_ = 0;
  std::vector<double> res_;
};

}  // namespace mc_model

using mc_model::PairModel;
using mc_model::TestModel;

namespace {

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

}  // namespace

void DbbUncertaintyOptions::Check() const {
  KM_OPTION_GE(draws, 20u);
}

namespace {

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

struct DbbPairModel::Impl {
  Impl(const DbbTestReport& rcw, const DbbTestReport& rccw, double ucw, double uccw) {
    a.Init(rcw, ucw);
    b.Init(rccw, uccw);
    pair = std::make_unique<PairModel>(rcw.circular, rccw.circular, a, b);
    shift.resize(a.size() + b.size());
  }
  TestModel a, b;
  std::unique_ptr<PairModel> pair;
  std::vector<double> shift;
};

DbbPairModel::DbbPairModel(const DbbTestReport& rcw, const DbbTestReport& rccw, double u_reading_cw,
                           double u_reading_ccw)
    : impl_(std::make_unique<Impl>(rcw, rccw, u_reading_cw, u_reading_ccw)) {}

DbbPairModel::~DbbPairModel() = default;

std::size_t DbbPairModel::cw_size() const {
  return impl_->a.size();
}

std::size_t DbbPairModel::ccw_size() const {
  return impl_->b.size();
}

void DbbPairModel::Evaluate(std::span<const double> z, double c, std::span<double> y) {
  Impl& m = *impl_;
  const std::size_t na = m.a.size();
  const std::span<double> sa = std::span<double>(m.shift).first(na);
  const std::span<double> sb = std::span<double>(m.shift).subspan(na);
  m.a.Shift(z.first(na), c, sa);
  m.b.Shift(z.subspan(na, m.b.size()), c, sb);
  m.a.Evaluate(sa, y.first(4));
  m.b.Evaluate(sb, y.subspan(4, 4));
  m.pair->Evaluate(m.shift, y.subspan(8, 2));
}

DbbUncertainty PropagateDbbTest(const DbbTest& test, const DbbTestReport& report,
                                const DbbInputUncertainty& u,
                                const DbbUncertaintyOptions& options) {
  options.Check();
  TestModel m;
  m.Init(report, u.reading_um);
  const std::size_t n = m.size();
  const double alpha_l = u.expansion_ppm_per_k * test.bar_length_mm * 1e-3;  // µm per K
  const auto inputs = Inputs(n, u.reading_um, u);
  std::vector<double> shift(n);
  const uncertainty::VectorModel model = [&](std::span<const double> x, std::span<double> y) {
    m.Shift(x.first(n), SharedBarError(x, n, alpha_l), shift);
    m.Evaluate(shift, y);
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
  options.Check();
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
  DbbPairModel pm(rcw, rccw, ucw.reading_um, uccw.reading_um);
  TestModel& a = pm.impl_->a;
  TestModel& b = pm.impl_->b;
  const std::size_t na = a.size(), nb = b.size();
  const double alpha_l = shared.expansion_ppm_per_k * cw.bar_length_mm * 1e-3;
  const auto inputs = Inputs(na + nb, std::max(ucw.reading_um, uccw.reading_um), shared);
  const uncertainty::VectorModel model = [&](std::span<const double> x, std::span<double> y) {
    pm.Evaluate(x.first(na + nb), SharedBarError(x, na + nb, alpha_l), y);
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
