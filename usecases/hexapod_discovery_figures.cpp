#include "usecases/hexapod_discovery_figures.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "analysis/hexapod/dbb_geometry.h"

#include <numbers>

namespace km::usecases {
namespace {

// The rms of rows [r0, r1) of a residual.
double RowsRms(const Eigen::VectorXd& v, int r0, int r1) {
  return r1 > r0 ? std::sqrt(v.segment(r0, r1 - r0).squaredNorm() / (r1 - r0)) : 0.0;
}

double TestRms(const hexapod::EffectFitData& d, const Eigen::VectorXd& v, std::size_t t) {
  return RowsRms(v, d.row_begin[t], d.row_begin[t + 1]);
}

}  // namespace

std::vector<TestGap> TestGaps(const hexapod::EffectFitData& d, const Eigen::VectorXd& before,
                              const Eigen::VectorXd* after, const std::vector<std::string>& names) {
  std::vector<TestGap> list;
  for (std::size_t t = 0; t < d.problem.tests.size(); ++t) {
    const auto& test = d.problem.tests[t];
    TestGap row{test.test_id, test.direction, std::nullopt, TestRms(d, before, t), std::nullopt};
    if (t < names.size()) row.file = names[t];
    if (after) row.gap_rms_after_um = TestRms(d, *after, t);
    list.push_back(std::move(row));
  }
  return list;
}

TestTraces WorstTestTraces(const hexapod::EffectFitData& d, const Eigen::VectorXd& before,
                           const Eigen::VectorXd& after) {
  std::size_t worst = 0;
  double worst_rms = -1.0;
  for (std::size_t t = 0; t < d.problem.tests.size(); ++t) {
    const double r = TestRms(d, before, t);
    if (r > worst_rms) {
      worst_rms = r;
      worst = t;
    }
  }
  const auto& test = d.problem.tests[worst];
  const auto& path = d.prepared.paths[worst];
  const Eigen::Vector3d& centre = test.fixed_ball_mm;
  const std::size_t n = test.samples.size();
  const std::size_t stride = std::max<std::size_t>(1, (n + 359) / 360);
  std::vector<double> th, m, mb, ma;
  const double bar0 = (path.pose.front().tip_mm - centre).norm();
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d aty = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; i += stride) {
    const int row = d.row_begin[worst] + static_cast<int>(i);
    const Eigen::Vector3d v = path.pose[i].tip_mm - centre;
    th.push_back(std::atan2(v.y(), v.x()));
    m.push_back(1000.0 * (test.samples[i].measured_bar_mm - bar0));
    mb.push_back(m.back() + before[row]);
    ma.push_back(m.back() + after[row]);
    const Eigen::Vector3d a(1.0, std::cos(th.back()), std::sin(th.back()));
    ata += a * a.transpose();
    aty += a * m.back();
  }
  const Eigen::Vector3d c = ata.ldlt().solve(aty);
  TestTraces out{test.test_id, test.direction, {}, {}, {}, {}};
  for (std::size_t k = 0; k < th.size(); ++k) {
    const double ref = c[0] + c[1] * std::cos(th[k]) + c[2] * std::sin(th[k]);
    out.angle_deg.push_back(th[k] * 180.0 / std::numbers::pi);
    out.measured_um.push_back(m[k] - ref);
    out.model_before_um.push_back(mb[k] - ref);
    out.model_after_um.push_back(ma[k] - ref);
  }
  return out;
}

HexapodDiscoveryFigures ComputeHexapodDiscoveryFigures(
    const hexapod::EffectFitData& data, const std::vector<hexapod::EffectFitResult>& history,
    const discovery::EngineResult& r, const std::vector<std::string>& names) {
  HexapodDiscoveryFigures out;
  out.base_tests = TestGaps(data, history.front().residual_um, nullptr, names);
  for (const auto& s : r.steps) {
    out.steps.push_back({TestGaps(data, s.before.residual, &s.after.residual, names),
                         WorstTestTraces(data, s.before.residual, s.after.residual)});
  }
  out.final_tests = TestGaps(data, history.back().residual_um, nullptr, names);
  out.compensation = hexapod::PreviewCompensation(data, history.back());
  return out;
}

}  // namespace km::usecases
