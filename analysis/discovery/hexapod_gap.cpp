#include "analysis/discovery/hexapod_gap.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>

namespace km::discovery {
namespace {

using Eigen::VectorXd;

// Angle of every sample of test t about its fixed ball, in the machine's XY plane.
std::vector<double> SampleAngles(const hexapod::EffectFitData& d, std::size_t t) {
  std::vector<double> a;
  const auto& f = d.problem.tests[t].fixed_ball_mm;
  for (const auto& pose : d.prepared.paths[t].pose)
    a.push_back(std::atan2(pose.tip_mm.y() - f.y(), pose.tip_mm.x() - f.x()));
  return a;
}

// Power of the gap in harmonic orders 1–8 over the circle, summed over the tests.
std::array<double, 9> HarmonicPower(const hexapod::EffectFitData& d, const VectorXd& gap) {
  std::array<double, 9> power{};
  for (std::size_t t = 0; t < d.problem.tests.size(); ++t) {
    const int r0 = d.row_begin[t], r1 = d.row_begin[t + 1];
    const auto th = SampleAngles(d, t);
    for (int k = 1; k <= 8; ++k) {
      double a = 0.0, b = 0.0;
      for (int r = r0; r < r1; ++r) {
        a += gap[r] * std::cos(k * th[static_cast<std::size_t>(r - r0)]);
        b += gap[r] * std::sin(k * th[static_cast<std::size_t>(r - r0)]);
      }
      const double n = std::max(1, r1 - r0);
      power[static_cast<std::size_t>(k)] += (a * a + b * b) * 2.0 / (n * n) * (r1 - r0);
    }
  }
  return power;
}

}  // namespace

double Correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const std::size_t n = a.size();
  if (n < 3) return 0.0;
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < n; ++i) {
    ma += a[i] / n;
    mb += b[i] / n;
  }
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0.0;
}

double SegmentRms(const VectorXd& v, int r0, int r1) {
  return r1 > r0 ? std::sqrt(v.segment(r0, r1 - r0).squaredNorm() / (r1 - r0)) : 0.0;
}

PairedRows::PairedRows(const hexapod::EffectFitData& d) {
  const auto& tests = d.problem.tests;
  std::map<std::string, std::pair<int, int>> pair;  // test_id → (ccw, cw)
  for (std::size_t t = 0; t < tests.size(); ++t) {
    auto& pr = pair.emplace(tests[t].test_id, std::make_pair(-1, -1)).first->second;
    (tests[t].direction == dbb::Direction::kCcw ? pr.first : pr.second) = static_cast<int>(t);
  }
  for (const auto& [id, pr] : pair) {
    if (pr.first < 0 || pr.second < 0) continue;
    const auto a = SampleAngles(d, static_cast<std::size_t>(pr.first));
    const auto b = SampleAngles(d, static_cast<std::size_t>(pr.second));
    std::vector<std::pair<double, int>> sorted;
    for (std::size_t k = 0; k < b.size(); ++k) sorted.emplace_back(b[k], static_cast<int>(k));
    std::sort(sorted.begin(), sorted.end());
    if (sorted.empty()) continue;
    for (std::size_t i = 0; i < a.size(); ++i) {
      auto it = std::lower_bound(sorted.begin(), sorted.end(), std::make_pair(a[i], -1));
      // Nearest of the two neighbours, around the circle.
      const auto hi = it == sorted.end() ? sorted.begin() : it;
      const auto lo = it == sorted.begin() ? sorted.end() - 1 : it - 1;
      const auto dist = [&](double x) { return std::abs(std::remainder(x - a[i], 2 * M_PI)); };
      const int k = dist(hi->first) <= dist(lo->first) ? hi->second : lo->second;
      rows_.emplace_back(d.row_begin[pr.first] + static_cast<int>(i), d.row_begin[pr.second] + k);
    }
  }
}

std::pair<double, double> PairedRows::EvenOdd(const VectorXd& v) const {
  double even = 0.0, odd = 0.0;
  for (const auto& [a, b] : rows_) {
    even += 0.25 * (v[a] + v[b]) * (v[a] + v[b]);
    odd += 0.25 * (v[a] - v[b]) * (v[a] - v[b]);
  }
  const double n = std::max<std::size_t>(1, rows_.size());
  return {even / n, odd / n};
}

double PairRepeatability(const PairedRows& pairs, const VectorXd& residual) {
  if (pairs.Rows().size() < 30) return 0.0;
  const auto [even, odd] = pairs.EvenOdd(residual);
  return std::sqrt(2.0 * std::min(even, odd));
}

GapFigures DescribeGapFigures(const hexapod::EffectFitData& d, const PairedRows& pairs,
                              const VectorXd& gap) {
  GapFigures out;
  auto& f = out.figures;
  const auto [even2, odd2] = pairs.EvenOdd(gap);
  const double tot = even2 + odd2;
  f["even_part_pct"] = tot > 0 ? 100.0 * std::sqrt(even2 / tot) : 0.0;
  f["odd_part_pct"] = tot > 0 ? 100.0 * std::sqrt(odd2 / tot) : 0.0;
  const auto& tests = d.problem.tests;
  std::vector<double> rms, tilt, time, strut, height, tool;
  std::vector<std::pair<std::string, double>> per_test;
  for (std::size_t t = 0; t < tests.size(); ++t) {
    const int r0 = d.row_begin[t], r1 = d.row_begin[t + 1];
    const auto& path = d.prepared.paths[t];
    rms.push_back(SegmentRms(gap, r0, r1));
    const auto& abc = path.pose.front().abc_rad;
    tilt.push_back(std::hypot(abc.x(), abc.y()) * 180.0 / std::numbers::pi);
    time.push_back(path.time_s.front());
    double mean_len = 0.0;
    for (const auto& fr : path.frame)
      for (double l : fr.length_mm) mean_len += l / (6.0 * path.frame.size());
    strut.push_back(mean_len);
    height.push_back(tests[t].fixed_ball_mm.z());
    tool.push_back(tests[t].tool_length_mm);
    per_test.emplace_back(
        tests[t].test_id + (path.direction == dbb::Direction::kCcw ? " ccw" : " cw"), rms.back());
  }
  f["correlation_with_tilt"] = Correlation(rms, tilt);
  f["correlation_with_time"] = Correlation(rms, time);
  f["correlation_with_strut_length"] = Correlation(rms, strut);
  f["correlation_with_ball_height"] = Correlation(rms, height);
  f["correlation_with_tool"] = Correlation(rms, tool);
  const auto power = HarmonicPower(d, gap);
  double total = gap.squaredNorm();
  const auto strongest = std::max_element(power.begin() + 1, power.end()) - power.begin();
  f["strongest_harmonic_order"] = static_cast<double>(strongest);
  f["strongest_harmonic_pct"] =
      total > 0 ? 100.0 * power[static_cast<std::size_t>(strongest)] / total : 0.0;
  double low = 0.0;
  for (int k = 1; k <= 8; ++k) low += power[static_cast<std::size_t>(k)];
  f["harmonics_1_to_8_pct"] = total > 0 ? std::min(100.0, 100.0 * low / total) : 0.0;
  std::sort(per_test.begin(), per_test.end(),
            [](const auto& a, const auto& b) { return a.second > b.second; });
  per_test.resize(std::min<std::size_t>(per_test.size(), 5));
  out.worst_tests = per_test;
  return out;
}

std::string ParityWords(double even_pct, double odd_pct) {
  char buf[160];
  const char* what = even_pct >= 80.0  ? "mostly even (alike in CW and CCW)"
                     : odd_pct >= 80.0 ? "mostly odd (opposite in CW and CCW)"
                                       : "partly even and partly odd";
  std::snprintf(buf, sizeof buf, "%s: even part %.0f %%, odd part %.0f %% of its RMS", what,
                even_pct, odd_pct);
  return buf;
}

std::string FollowsWords(const char* what, double r) {
  char buf[120];
  const char* verb = std::abs(r) >= 0.7   ? "follows"
                     : std::abs(r) >= 0.4 ? "partly follows"
                                          : "does not follow";
  std::snprintf(buf, sizeof buf, "%s %s (r = %.2f)", verb, what, r);
  return buf;
}

std::string MisfitSentence(const GapFigures& g, double gap_rms_um, double repeat_um) {
  const auto& f = g.figures;
  char head[240];
  std::snprintf(head, sizeof head,
                "No registered effect explains the remaining gap of %.3g um RMS (what repeated "
                "runs do not share: %.3g um). It is ",
                gap_rms_um, repeat_um);
  std::string s = head + ParityWords(f.at("even_part_pct"), f.at("odd_part_pct"));
  s += f.at("even_part_pct") >= 80.0
           ? " — a geometric or static error rather than friction or lag"
           : (f.at("odd_part_pct") >= 80.0 ? " — it depends on the direction of motion" : "");
  char tail[400];
  std::snprintf(tail, sizeof tail,
                "; its strongest harmonic over the circle is order %.0f (%.0f %% of its power, "
                "orders 1–8 together %.0f %%); its size per test ",
                f.at("strongest_harmonic_order"), f.at("strongest_harmonic_pct"),
                f.at("harmonics_1_to_8_pct"));
  s += tail;
  s += FollowsWords("the tilt", f.at("correlation_with_tilt")) + ", " +
       FollowsWords("the time", f.at("correlation_with_time")) + ", " +
       FollowsWords("the mean strut length", f.at("correlation_with_strut_length")) + ", " +
       FollowsWords("the fixed-ball height", f.at("correlation_with_ball_height"));
  if (!g.worst_tests.empty()) {
    s += "; largest in";
    for (std::size_t k = 0; k < g.worst_tests.size() && k < 3; ++k) {
      char t[120];
      std::snprintf(t, sizeof t, "%s %s (%.3g um)", k ? "," : "", g.worst_tests[k].first.c_str(),
                    g.worst_tests[k].second);
      s += t;
    }
  }
  return s + ".";
}

}  // namespace km::discovery
