#include "tests/unit/discovery/serial_truth.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include <Eigen/Core>
#include <Eigen/QR>

namespace km::test::truth {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

double Sign(double x) {
  return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0);
}

// Unit vectors of the plane axes (first, second) and the normal, per docs/formats.md §1.1.
std::array<std::array<double, 3>, 3> Axes(const std::string& plane) {
  if (plane == "YZ") return {{{0, 1, 0}, {0, 0, 1}, {1, 0, 0}}};
  if (plane == "ZX") return {{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}}};
  if (plane == "XY") return {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  throw std::invalid_argument("plane " + plane);
}

char Letter(const std::string& plane, int axis) {
  const char a = static_cast<char>(std::tolower(static_cast<unsigned char>(plane[0])));
  const char b = static_cast<char>(std::tolower(static_cast<unsigned char>(plane[1])));
  return axis == 0 ? a : b;
}

// Velocity component of axis `axis` over V: u → −s sin θ, v → s cos θ.
double UnitVelocity(int axis, int s, double theta) {
  return axis == 0 ? -s * std::sin(theta) : s * std::cos(theta);
}

// Angle (rad) travelled since the last reversal of the axis, along the motion, in [0, π).
double SinceReversal(int axis, int s, double theta) {
  const double theta0 = axis == 0 ? 0.0 : kPi / 2.0;
  const double prog = s * (theta - theta0);
  return prog - kPi * std::floor(prog / kPi);
}

int NumLinear(Kind k) {
  return k == Kind::kCyclicError ? 2 : 1;
}

double Uniform(std::mt19937& rng, double a, double b) {
  return std::uniform_real_distribution<double>(a, b)(rng);
}

double SignedUniform(std::mt19937& rng, double a, double b) {
  return (Uniform(rng, 0.0, 1.0) < 0.5 ? -1.0 : 1.0) * Uniform(rng, a, b);
}

}  // namespace

std::string Name(const Effect& e, const std::string& plane) {
  const std::string ax = std::string("_") + Letter(plane, e.axis);
  switch (e.kind) {
    case Kind::kBacklash:
      return "backlash" + ax;
    case Kind::kReversalSpike:
      return "reversal_spike" + ax;
    case Kind::kSquareness:
      return "squareness";
    case Kind::kScaleMismatch:
      return "scale_mismatch";
    case Kind::kServoMismatch:
      return "servo_mismatch";
    case Kind::kCyclicError:
      return "cyclic_error" + ax;
    case Kind::kLateralPlay:
      return "lateral_play" + ax;
    case Kind::kStraightness:
      return "straightness" + ax;
    case Kind::kSoftBacklash:
    default:
      return "";
  }
}

double Value(const Effect& e) {
  return e.kind == Kind::kCyclicError ? std::hypot(e.p[0], e.p[1]) : e.p[0];
}

std::array<double, 2> PositionErrorUm(const Effect& e, const Test& t, double theta) {
  const int a = e.axis, o = 1 - e.axis, s = t.direction;
  const double c = std::cos(theta), sn = std::sin(theta);
  const double u_mm = t.radius_mm * c, v_mm = t.radius_mm * sn;
  const double speed = t.feed_mm_min / 60.0;  // mm/s
  std::array<double, 2> err{0.0, 0.0};
  switch (e.kind) {
    case Kind::kBacklash:
      err[a] = -0.5 * e.p[0] * Sign(UnitVelocity(a, s, theta));
      break;
    case Kind::kSoftBacklash: {
      const double phi = SinceReversal(a, s, theta);
      err[a] = -0.5 * e.p[0] * Sign(UnitVelocity(a, s, theta)) *
               (1.0 - 2.0 * std::exp(-phi / (e.p[1] * kDeg)));
      break;
    }
    case Kind::kReversalSpike: {
      const double phi = SinceReversal(a, s, theta);
      err[a] = -e.p[0] * Sign(UnitVelocity(a, s, theta)) * std::exp(-phi / (e.p[1] * kDeg));
      break;
    }
    case Kind::kSquareness:
      err[0] = -e.p[0] * 1e-6 * v_mm * 1e3;
      break;
    case Kind::kScaleMismatch:
      err[0] = 0.5 * e.p[0] * 1e-6 * u_mm * 1e3;
      err[1] = -0.5 * e.p[0] * 1e-6 * v_mm * 1e3;
      break;
    case Kind::kServoMismatch: {
      const double tau_u = 0.5 * e.p[0], tau_v = -0.5 * e.p[0];  // ms
      err[0] = -tau_u * speed * UnitVelocity(0, s, theta);       // ms · mm/s = µm
      err[1] = -tau_v * speed * UnitVelocity(1, s, theta);
      break;
    }
    case Kind::kCyclicError: {
      const double pos = a == 0 ? u_mm : v_mm;
      const double arg = 2.0 * kPi * pos / e.p[2];
      err[a] = e.p[0] * std::cos(arg) + e.p[1] * std::sin(arg);
      break;
    }
    case Kind::kLateralPlay:
      err[o] = -0.5 * e.p[0] * Sign(UnitVelocity(a, s, theta));
      break;
    case Kind::kStraightness: {
      const double q = (a == 0 ? u_mm : v_mm) / t.radius_mm;
      err[o] = e.p[0] * (1.0 - q * q);
      break;
    }
  }
  return err;
}

double BarDeviationUm(const Machine& m, const std::vector<Effect>& effects, const Test& t,
                      double theta) {
  const auto ax = Axes(m.plane);
  // Where the axes are: the commanded angle and radius, or the loop's steady state.
  double th = theta, r = t.radius_mm;
  if (m.servo_kpp_per_s > 0.0) {
    const double w = t.feed_mm_min / 60.0 / t.radius_mm;  // rad/s
    const std::complex<double> g(m.servo_kpp_per_s, w * m.servo_kf);
    const std::complex<double> h = g / std::complex<double>(m.servo_kpp_per_s, w);
    th = theta + t.direction * std::arg(h);
    r = t.radius_mm * std::abs(h);
  }
  double eu = 0.0, ev = 0.0;
  for (const auto& e : effects) {
    const auto d = PositionErrorUm(e, t, th);
    eu += d[0];
    ev += d[1];
  }
  // P − F = r n + e − (fixed-ball set-up error), all in mm; C cancels.
  const double pu = r * std::cos(th) + 1e-3 * (eu - m.fixed_ball_offset_um[0]);
  const double pv = r * std::sin(th) + 1e-3 * (ev - m.fixed_ball_offset_um[1]);
  double d2 = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double x = pu * ax[0][k] + pv * ax[1][k];
    d2 += x * x;
  }
  return (std::sqrt(d2) - t.radius_mm) * 1000.0;
}

std::string DbbFile(const Machine& m, const Test& t) {
  char buf[160];
  std::string out = "# format: kinemetric-dbb/1\n";
  out += "# machine_id: " + m.machine_id + "\n";
  out += "# test_id: " + t.test_id + "\n";
  out += std::string("# direction: ") + (t.direction > 0 ? "ccw" : "cw") + "\n";
  out += "# plane: " + m.plane + "\n";
  std::snprintf(buf, sizeof buf, "# bar_length_mm: %.6f\n# radius_mm: %.6f\n", t.radius_mm,
                t.radius_mm);
  out += buf;
  std::snprintf(buf, sizeof buf, "# centre_mm: %.6f, %.6f, %.6f\n", m.centre_mm[0], m.centre_mm[1],
                m.centre_mm[2]);
  out += buf;
  std::snprintf(buf, sizeof buf, "# feed_mm_min: %.6f\n", t.feed_mm_min);
  out += buf;
  out += "angle_deg,dr_um\n";
  std::mt19937 rng(t.seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  const auto n = static_cast<int>(std::lround(360.0 / t.step_deg));
  const double rho = std::exp(-t.step_deg / m.smooth_noise_corr_deg);
  double smooth = m.smooth_noise_um * noise(rng);
  for (int i = 0; i < n; ++i) {
    const double deg = t.start_deg + t.direction * i * t.step_deg;
    if (i > 0) smooth = rho * smooth + std::sqrt(1.0 - rho * rho) * m.smooth_noise_um * noise(rng);
    const double dr = BarDeviationUm(m, m.effects, t, deg * kDeg) + m.noise_um * noise(rng) +
                      smooth + m.drift_um_per_turn * i / static_cast<double>(n);
    std::snprintf(buf, sizeof buf, "%.9f,%.6f\n", deg, dr);
    out += buf;
  }
  return out;
}

double Detectability(const Machine& m, std::size_t k) {
  // Samples of every test, as written (same angles).
  std::vector<std::pair<std::size_t, double>> rows;  // (test, θ)
  for (std::size_t ti = 0; ti < m.tests.size(); ++ti) {
    const auto& t = m.tests[ti];
    const auto n = static_cast<int>(std::lround(360.0 / t.step_deg));
    for (int i = 0; i < n; ++i)
      rows.emplace_back(ti, (t.start_deg + t.direction * i * t.step_deg) * kDeg);
  }
  const auto nr = static_cast<Eigen::Index>(rows.size());
  // d dr / d (linear parameter j of effect e), central differences of the exact bar length.
  auto column = [&](std::size_t e, int j) {
    Eigen::VectorXd col(nr);
    const double h = std::max(1e-3, 1e-3 * std::abs(m.effects[e].p[static_cast<std::size_t>(j)]));
    std::vector<Effect> plus = m.effects, minus = m.effects;
    plus[e].p[static_cast<std::size_t>(j)] += h;
    minus[e].p[static_cast<std::size_t>(j)] -= h;
    for (Eigen::Index r = 0; r < nr; ++r) {
      const auto& [ti, th] = rows[static_cast<std::size_t>(r)];
      col[r] =
          (BarDeviationUm(m, plus, m.tests[ti], th) - BarDeviationUm(m, minus, m.tests[ti], th)) /
          (2.0 * h);
    }
    return col;
  };
  std::vector<Eigen::VectorXd> others;
  for (std::size_t ti = 0; ti < m.tests.size(); ++ti) {
    Eigen::VectorXd c = Eigen::VectorXd::Zero(nr), s = c, one = c;
    for (Eigen::Index r = 0; r < nr; ++r) {
      if (rows[static_cast<std::size_t>(r)].first != ti) continue;
      const double th = rows[static_cast<std::size_t>(r)].second;
      c[r] = std::cos(th);
      s[r] = std::sin(th);
      one[r] = 1.0;
    }
    others.push_back(c);
    others.push_back(s);
    others.push_back(one);
  }
  Eigen::VectorXd contribution = Eigen::VectorXd::Zero(nr);
  for (std::size_t e = 0; e < m.effects.size(); ++e) {
    for (int j = 0; j < NumLinear(m.effects[e].kind); ++j) {
      Eigen::VectorXd col = column(e, j);
      if (e == k)
        contribution += m.effects[e].p[static_cast<std::size_t>(j)] * col;
      else
        others.push_back(std::move(col));
    }
  }
  Eigen::MatrixXd a(nr, static_cast<Eigen::Index>(others.size()));
  for (std::size_t c = 0; c < others.size(); ++c) a.col(static_cast<Eigen::Index>(c)) = others[c];
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(a);
  const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(nr, a.cols());
  const Eigen::VectorXd left = contribution - q * (q.transpose() * contribution);
  return left.norm() / m.noise_um;
}

Machine RandomMachine(std::mt19937& rng, int n_effects, const std::string& machine_id) {
  Machine m;
  m.machine_id = machine_id;
  const char* planes[] = {"XY", "YZ", "ZX"};
  m.plane = planes[std::uniform_int_distribution<int>(0, 2)(rng)];
  m.centre_mm = {Uniform(rng, -200, 200), Uniform(rng, -200, 200), Uniform(rng, -100, 100)};
  m.fixed_ball_offset_um = {Uniform(rng, -8, 8), Uniform(rng, -8, 8)};
  m.noise_um = Uniform(rng, 0.2, 0.5);
  std::vector<Kind> kinds = {Kind::kBacklash,      Kind::kReversalSpike, Kind::kSquareness,
                             Kind::kScaleMismatch, Kind::kServoMismatch, Kind::kCyclicError,
                             Kind::kLateralPlay,   Kind::kStraightness};
  std::shuffle(kinds.begin(), kinds.end(), rng);
  const double radius = Uniform(rng, 0.0, 1.0) < 0.5 ? 100.0 : 150.0;
  for (int i = 0; i < n_effects; ++i) {
    Effect e;
    e.kind = kinds[static_cast<std::size_t>(i)];
    e.axis = std::uniform_int_distribution<int>(0, 1)(rng);
    switch (e.kind) {
      case Kind::kBacklash:  // one in four over-compensated by the control (b < 0)
        e.p = {Uniform(rng, 0.8, 6.0) * (Uniform(rng, 0.0, 1.0) < 0.25 ? -1.0 : 1.0)};
        break;
      case Kind::kReversalSpike:
        e.p = {Uniform(rng, 2.0, 8.0), Uniform(rng, 0.4, 3.5)};
        break;
      case Kind::kSquareness:
        e.p = {SignedUniform(rng, 4.0, 40.0)};
        break;
      case Kind::kScaleMismatch:
        e.p = {SignedUniform(rng, 4.0, 40.0)};
        break;
      case Kind::kServoMismatch:
        e.p = {SignedUniform(rng, 0.15, 1.5)};
        break;
      case Kind::kCyclicError: {
        const double amp = Uniform(rng, 0.4, 2.0), ph = Uniform(rng, 0.0, 2.0 * kPi);
        e.p = {amp * std::cos(ph), amp * std::sin(ph), Uniform(rng, 2.0, 25.0)};
        break;
      }
      case Kind::kLateralPlay:
        e.p = {Uniform(rng, 0.8, 5.0)};
        break;
      case Kind::kStraightness:
        e.p = {SignedUniform(rng, 0.8, 5.0)};
        break;
      default:
        break;
    }
    m.effects.push_back(e);
  }
  const int ids = std::uniform_int_distribution<int>(1, 2)(rng);
  for (int id = 0; id < ids; ++id) {
    const double feed = Uniform(rng, 500.0, 3000.0);
    const double start = Uniform(rng, 0.0, 360.0);
    for (int dir : {+1, -1}) {
      Test t;
      t.test_id = "F" + std::to_string(id + 1);
      t.direction = dir;
      t.feed_mm_min = feed;
      t.radius_mm = radius;
      t.start_deg = start;
      t.step_deg = 0.1;
      t.seed = static_cast<std::uint32_t>(rng());
      m.tests.push_back(t);
    }
  }
  return m;
}

}  // namespace km::test::truth
