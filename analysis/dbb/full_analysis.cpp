#include "analysis/dbb/full_analysis.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <tuple>

#include <Eigen/Core>
#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/effects/registry.h"

namespace km::dbb {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// A diagnosis unit: one test, or a cw + ccw pair (same test_id, same plane).
struct Unit {
  std::vector<std::size_t> tests;
  DiagnosisResult result;
};

DiagnosisEntry* FindEntry(std::vector<DiagnosisEntry>& v, effects::EffectId id) {
  for (auto& e : v)
    if (e.id == id) return &e;
  return nullptr;
}

void SeparateServoLag(const std::vector<DbbTest>& tests, std::vector<Unit>& units,
                      const DiagnosisOptions& opt) {
  // Group units by machine, plane, radius and centre.
  std::map<std::tuple<std::string, int, long long, long long, long long, long long>,
           std::vector<std::size_t>>
      groups;
  for (std::size_t u = 0; u < units.size(); ++u) {
    const DbbTest& t = tests[units[u].tests.front()];
    auto q = [](double v) { return static_cast<long long>(std::llround(v * 1000.0)); };
    groups[{t.machine_id, static_cast<int>(t.plane), q(t.radius_mm), q(t.centre_mm[0]),
            q(t.centre_mm[1]), q(t.centre_mm[2])}]
        .push_back(u);
  }
  for (const auto& [key, members] : groups) {
    std::vector<double> g, m, s;
    for (std::size_t u : members) {
      const DbbTest& t = tests[units[u].tests.front()];
      effects::EffectContext ctx;
      ctx.radius_mm = t.radius_mm;
      ctx.feed_mm_min = t.feed_mm_min;
      const DiagnosisEntry* r = nullptr;
      for (const auto& e : units[u].result.candidates)
        if (e.id == effects::EffectId::kRadiusError) r = &e;
      if (!r) continue;
      g.push_back(effects::ServoLag::Gain(ctx));
      m.push_back(r->value[0]);
      s.push_back(r->uncertainty[0]);
    }
    const auto [gmin, gmax] = std::minmax_element(g.begin(), g.end());
    if (g.size() < 2 || *gmax - *gmin < 1e-12 + 0.05 * std::abs(*gmin)) continue;
    const std::size_t n = g.size();
    Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
    Eigen::Vector2d atb = Eigen::Vector2d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d row(1.0, g[i]);
      ata += row * row.transpose();
      atb += row * m[i];
    }
    const Eigen::Vector2d x = ata.inverse() * atb;
    double rss = 0.0, s2 = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      rss += std::pow(m[i] - x[0] - x[1] * g[i], 2);
      s2 += s[i] * s[i];
    }
    double sigma2 = s2 / static_cast<double>(n);
    if (n > 2) sigma2 = std::max(sigma2, rss / static_cast<double>(n - 2));
    const Eigen::Matrix2d cov = sigma2 * ata.inverse();
    for (std::size_t k = 0; k < n; ++k) {
      Unit& unit = units[members[k]];
      auto& cands = unit.result.candidates;
      auto& named = unit.result.named;
      // radius_error = ρ; servo_lag = c·g_k.
      DiagnosisEntry* rc = FindEntry(cands, effects::EffectId::kRadiusError);
      if (!rc) continue;
      DiagnosisEntry re = *rc;
      re.value = {x[0]};
      re.params = re.value;
      re.uncertainty = {std::sqrt(cov(0, 0))};
      re.significance = std::min(std::abs(x[0]) / std::max(re.uncertainty[0], 1e-300), 1e9);
      re.named = re.significance > opt.significance;
      DiagnosisEntry sl = re;
      sl.id = effects::EffectId::kServoLag;
      sl.effect = effects::EffectName(sl.id);
      sl.unit = effects::Info(sl.id).unit;
      sl.value = {x[1] * g[k]};
      sl.params = {x[1]};
      sl.uncertainty = {std::abs(g[k]) * std::sqrt(cov(1, 1))};
      sl.significance = std::min(std::abs(sl.value[0]) / std::max(sl.uncertainty[0], 1e-300), 1e9);
      sl.named = sl.significance > opt.significance;
      *rc = re;
      cands.push_back(sl);
      named.erase(std::remove_if(named.begin(), named.end(),
                                 [](const DiagnosisEntry& e) {
                                   return e.id == effects::EffectId::kRadiusError;
                                 }),
                  named.end());
      if (re.named) named.push_back(re);
      if (sl.named) named.push_back(sl);
    }
  }
}

// The diagnosis takes bar deviations and converts them to the tool path itself (diagnosis.h):
// the report's tool-path deviations divided back by the factor (exact for a flat test, 1).
std::vector<double> BarDeviation(const DbbTestReport& t, std::vector<double> dev) {
  for (double& d : dev) d /= t.circular.deviation_factor;
  return dev;
}

std::string Where(const DbbTest& t, std::size_t i) {
  return t.test_id.empty() ? "test #" + std::to_string(i + 1) : "test " + t.test_id;
}

}  // namespace

DbbReport AnalyzeDbbSet(const std::vector<DbbTest>& tests, const DbbAnalysisOptions& opt) {
  if (tests.empty()) throw InvalidInput("", 0, "tests", "no DBB test given");
  opt.diagnosis.Check();
  DbbReport rep;
  rep.tests.resize(tests.size());
  std::vector<std::vector<double>> devs(tests.size());  // deviation about the nominal centre
  for (std::size_t i = 0; i < tests.size(); ++i) {
    const DbbTest& t = tests[i];
    DbbTestReport& tr = rep.tests[i];
    try {
      tr.circular = AnalyzeCircularTest(t, DeviationUnits::kToolPath);
      tr.plane = t.plane;
      tr.iso230_4 = ComputeIso230(tr.circular);
      // Minimum zone on the planar representation about the nominal centre (µm).
      const double rn = NominalRadiusUm(tr.circular);
      devs[i] = DeviationAboutNominalCentre(tr.circular);
      const auto& dev = devs[i];
      std::vector<Eigen::Vector2d> pts(dev.size());
      for (std::size_t k = 0; k < dev.size(); ++k) {
        pts[k] =
            (rn + dev[k]) * Eigen::Vector2d(CosAngle(tr.circular, k), SinAngle(tr.circular, k));
      }
      tr.min_zone = geometry::FitMinZoneCircle(
          pts, Eigen::Vector2d(tr.circular.centre_offset_um[0], tr.circular.centre_offset_um[1]));
      tr.min_zone_circularity_um = tr.min_zone.width;
      std::vector<double> c(dev.size()), s(dev.size());
      for (std::size_t k = 0; k < dev.size(); ++k) {
        c[k] = CosAngle(tr.circular, k);
        s[k] = SinAngle(tr.circular, k);
      }
      tr.harmonics = FitHarmonics(
          c, s, tr.circular.mode == Mode::kAbsolute ? dev : tr.circular.radial_error_um,
          std::min(opt.harmonic_orders, static_cast<int>((dev.size() - 1) / 2)));
    } catch (const InvalidInput& e) {
      throw InvalidInput(e.file(), e.line(), e.field(), Where(t, i) + ": " + e.reason());
    }
  }
  // Pairs: exactly one cw and one ccw with the same test_id.
  std::map<std::string, std::vector<std::size_t>> by_id;
  for (std::size_t i = 0; i < tests.size(); ++i) by_id[tests[i].test_id].push_back(i);
  std::vector<bool> in_pair(tests.size(), false);
  std::vector<Unit> units;
  for (const auto& [id, idx] : by_id) {
    if (idx.size() != 2) continue;
    std::size_t cw = idx[0], ccw = idx[1];
    if (tests[cw].direction == Direction::kCcw) std::swap(cw, ccw);
    if (tests[cw].direction != Direction::kCw || tests[ccw].direction != Direction::kCcw) continue;
    DbbPairReport pr;
    pr.test_id = id;
    pr.cw = cw;
    pr.ccw = ccw;
    try {
      pr.iso230_4 =
          ComputeIso230Pair(rep.tests[cw].circular, rep.tests[ccw].circular, devs[cw], devs[ccw]);
    } catch (const InvalidInput&) {
      continue;  // partial arcs that do not overlap: two separate tests, not a pair
    }
    rep.tests[cw].pair = rep.pairs.size();
    rep.tests[ccw].pair = rep.pairs.size();
    rep.pairs.push_back(pr);
    if (tests[cw].plane == tests[ccw].plane) {
      in_pair[cw] = in_pair[ccw] = true;
      units.push_back(Unit{{ccw, cw}, {}});
    }
  }
  for (std::size_t i = 0; i < tests.size(); ++i)
    if (!in_pair[i]) units.push_back(Unit{{i}, {}});
  std::sort(units.begin(), units.end(),
            [](const Unit& a, const Unit& b) { return a.tests.front() < b.tests.front(); });
  if (!opt.diagnose) return rep;
  for (auto& u : units) {
    std::vector<DiagnosisTrace> tr;
    for (std::size_t i : u.tests) {
      tr.push_back(
          MakeDiagnosisTrace(tests[i], rep.tests[i].circular, BarDeviation(rep.tests[i], devs[i])));
    }
    try {
      u.result = DiagnoseSerialDbb(tr, tests[u.tests.front()].plane, opt.diagnosis);
    } catch (const NotObservable& e) {
      u.result = DiagnosisResult{};
      u.result.not_identifiable.push_back(std::string("diagnosis not possible: ") + e.what());
    }
  }
  SeparateServoLag(tests, units, opt.diagnosis);
  for (const auto& u : units) {
    for (std::size_t k = 0; k < u.tests.size(); ++k) {
      DbbTestReport& tr = rep.tests[u.tests[k]];
      tr.not_identifiable = u.result.not_identifiable;
      for (const auto& e : u.result.named) {
        DiagnosisEntry en = e;
        const double c = k < e.contribution_pct.size() ? e.contribution_pct[k] : 0.0;
        en.contribution_pct = {c};
        tr.diagnosis.push_back(std::move(en));
      }
      std::stable_sort(tr.diagnosis.begin(), tr.diagnosis.end(),
                       [](const DiagnosisEntry& a, const DiagnosisEntry& b) {
                         if (a.contribution_pct[0] != b.contribution_pct[0])
                           return a.contribution_pct[0] > b.contribution_pct[0];
                         return a.significance > b.significance;
                       });
    }
  }
  return rep;
}

std::vector<unsigned char> PolarPlotPng(const DbbReport& report, std::size_t test_index,
                                        const PolarPlotOptions& options) {
  if (test_index >= report.tests.size()) throw InvalidInput("", 0, "test", "no such test");
  const DbbTestReport& t = report.tests[test_index];
  std::vector<std::size_t> idx{test_index};
  if (t.pair) {
    const auto& p = report.pairs[*t.pair];
    idx = {p.ccw, p.cw};
  }
  // Deviations of every trace about the chosen test's least-squares centre.
  const double cx = t.circular.centre_offset_um[0], cy = t.circular.centre_offset_um[1];
  const double r0 = t.circular.fitted_radius_mm * 1000.0;
  std::vector<PolarPlotTrace> traces;
  for (std::size_t i : idx) {
    const auto& c = report.tests[i].circular;
    const double rn = NominalRadiusUm(c);
    const auto dev = DeviationAboutNominalCentre(c);
    PolarPlotTrace pt;
    pt.label = ToString(c.direction);
    pt.bgr = c.direction == Direction::kCcw ? std::array<unsigned char, 3>{200, 60, 20}
                                            : std::array<unsigned char, 3>{30, 30, 210};
    for (std::size_t k = 0; k < dev.size(); ++k) {
      const double a = c.angle_deg[k] * kDeg;
      const Eigen::Vector2d q = (rn + dev[k]) * Eigen::Vector2d(std::cos(a), std::sin(a));
      pt.angle_rad.push_back(std::atan2(q.y() - cy, q.x() - cx));
      pt.dev_um.push_back(std::hypot(q.x() - cx, q.y() - cy) - r0);
    }
    traces.push_back(std::move(pt));
  }
  PolarPlotZone z;
  z.centre_um = {t.min_zone.centre.x() - cx, t.min_zone.centre.y() - cy};
  z.inner_um = t.min_zone.inner_radius - r0;
  z.outer_um = t.min_zone.outer_radius - r0;
  PolarPlotOptions o = options;
  if (o.title.empty()) o.title = "DBB " + t.circular.test_id + " " + ToString(t.plane);
  const auto [a, b] = AxisLetters(t.plane);
  o.first_axis = std::string(1, static_cast<char>(a - 'a' + 'A'));
  o.second_axis = std::string(1, static_cast<char>(b - 'a' + 'A'));
  return RenderPolarPlot(traces, z, o);
}

}  // namespace km::dbb
