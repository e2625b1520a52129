#include "analysis/dbb/serial_sim.h"

#include <cmath>
#include <numbers>
#include <random>

#include "analysis/core/errors.h"
#include "analysis/dbb/circular_test.h"

namespace km::dbb {

namespace {

std::vector<double> FullParams(const SimEffect& e) {
  const auto& info = serial_effects::Info(e.id);
  std::vector<double> p = e.params;
  if (static_cast<int>(p.size()) < info.num_linear) {
    throw InvalidInput("", 0, "effects", "too few parameters for " + info.base_name);
  }
  for (int i = static_cast<int>(p.size()); i < info.num_params; ++i) {
    p.push_back(info.default_shape[static_cast<std::size_t>(i - info.num_linear)]);
  }
  return p;
}

}  // namespace

std::array<double, 2> SimulatedPositionErrorUm(const SerialDbbSimOptions& o, double theta) {
  serial_effects::EffectContext ctx;
  ctx.radius_mm = o.radius_mm;
  ctx.feed_mm_min = o.feed_mm_min;
  ctx.direction = o.direction == Direction::kCcw ? 1 : -1;
  const auto a = serial_effects::MakeAngle(theta);
  std::array<double, 2> sum{0.0, 0.0};
  for (const auto& eff : o.effects) {
    const auto p = FullParams(eff);
    double e[2];
    serial_effects::PositionErrorT<double>(eff.id, ctx, a, p.data(), e);
    sum[0] += e[0];
    sum[1] += e[1];
  }
  return sum;
}

DbbTest SimulateSerialDbbTest(const SerialDbbSimOptions& o) {
  if (!(o.radius_mm > 0.0) || !(o.bar_length_mm > 0.0) || !(o.step_deg > 0.0)) {
    throw InvalidInput("", 0, "options", "radius, bar length and step must be positive");
  }
  DbbTest t;
  t.machine_id = o.machine_id;
  t.test_id = o.test_id;
  t.direction = o.direction;
  t.plane = o.plane;
  t.bar_length_mm = o.bar_length_mm;
  t.radius_mm = o.radius_mm;
  t.centre_mm = o.centre_mm;
  t.z_offset_mm = o.z_offset_mm;
  t.feed_mm_min = o.feed_mm_min;
  const auto ax = PlaneAxes(o.plane);
  std::array<double, 3> fixed{};
  for (int k = 0; k < 3; ++k) {
    fixed[k] = o.centre_mm[k] +
               1e-3 * (o.fixed_ball_offset_um[0] * ax[0][k] + o.fixed_ball_offset_um[1] * ax[1][k]);
  }
  if (o.absolute) t.fixed_ball_mm = fixed;
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double s = o.direction == Direction::kCcw ? 1.0 : -1.0;
  const double span = 360.0 + 2.0 * o.lead_deg;
  const auto n = static_cast<std::size_t>(std::llround(span / o.step_deg));
  t.angle_deg.reserve(n);
  t.dr_um.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double deg = o.start_deg + s * (-o.lead_deg + static_cast<double>(i) * o.step_deg);
    const double th = deg * std::numbers::pi / 180.0;
    const auto e = SimulatedPositionErrorUm(o, th);
    const auto p = CommandedBallPosition(t, th);
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double pk = p[k] + 1e-3 * (e[0] * ax[0][k] + e[1] * ax[1][k]);
      d2 += (pk - fixed[k]) * (pk - fixed[k]);
    }
    t.angle_deg.push_back(deg);
    t.dr_um.push_back((std::sqrt(d2) - o.bar_length_mm) * 1000.0 + o.noise_um * noise(rng));
  }
  return t;
}

}  // namespace km::dbb
