#include "analysis/dbb/full_analysis.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <map>
#include <numbers>
#include <optional>
#include <thread>
#include <tuple>

#include <Eigen/Core>
#include <Eigen/LU>

#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"
#include "analysis/core/parallel.h"
#include "analysis/serial_effects/registry.h"

namespace km::dbb {

namespace {

// A diagnosis unit: one test, or a cw + ccw pair (same test_id, same plane).
struct Unit {
  std::vector<std::size_t> tests;
  DiagnosisResult result;
};

DiagnosisEntry* FindEntry(std::vector<DiagnosisEntry>& v, serial_effects::EffectId id) {
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
      serial_effects::EffectContext ctx;
      ctx.radius_mm = t.radius_mm;
      ctx.feed_mm_min = t.feed_mm_min;
      const DiagnosisEntry* r = nullptr;
      for (const auto& e : units[u].result.candidates)
        if (e.id == serial_effects::EffectId::kRadiusError) r = &e;
      if (!r) continue;
      g.push_back(serial_effects::ServoLag::Gain(ctx));
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
      DiagnosisEntry* rc = FindEntry(cands, serial_effects::EffectId::kRadiusError);
      if (!rc) continue;
      DiagnosisEntry re = *rc;
      re.value = {x[0]};
      re.params = re.value;
      re.uncertainty = {std::sqrt(cov(0, 0))};
      re.significance = std::min(std::abs(x[0]) / std::max(re.uncertainty[0], 1e-300), 1e9);
      re.named = re.significance > opt.significance;
      DiagnosisEntry sl = re;
      sl.id = serial_effects::EffectId::kServoLag;
      sl.effect = serial_effects::EffectName(sl.id);
      sl.unit = serial_effects::Info(sl.id).unit;
      sl.value = {x[1] * g[k]};
      sl.params = {x[1]};
      sl.uncertainty = {std::abs(g[k]) * std::sqrt(cov(1, 1))};
      sl.significance = std::min(std::abs(sl.value[0]) / std::max(sl.uncertainty[0], 1e-300), 1e9);
      sl.named = sl.significance > opt.significance;
      *rc = re;
      cands.push_back(sl);
      named.erase(std::remove_if(named.begin(), named.end(),
                                 [](const DiagnosisEntry& e) {
                                   return e.id == serial_effects::EffectId::kRadiusError;
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

unsigned Threads(const DbbAnalysisOptions& opt) {
  return opt.threads > 0 ? opt.threads : std::max(1u, std::thread::hardware_concurrency());
}

std::string Where(const DbbTest& t, std::size_t i) {
  return t.test_id.empty() ? "test #" + std::to_string(i + 1) : "test " + t.test_id;
}

// Figures of test i the pair figures and the diagnosis need: circle and ISO 230-4; `dev`
// receives the deviation about the nominal centre.
void AnalyzeCircle(const DbbTest& t, std::size_t i, DbbTestReport& tr, std::vector<double>& dev) {
  try {
    tr.circular = AnalyzeCircularTest(t, DeviationUnits::kToolPath);
    tr.plane = t.plane;
    tr.iso230_4 = ComputeIso230(tr.circular);
    dev = DeviationAboutNominalCentre(tr.circular);
  } catch (const InvalidInput& e) {
    throw InvalidInput(e.file(), e.line(), e.field(), Where(t, i) + ": " + e.reason());
  }
}

// Form figures of test i, computed beside the diagnosis (two jobs): minimum zone (on the planar
// representation about the nominal centre, µm) and harmonics.
void MinZone(const DbbTest& t, std::size_t i, DbbTestReport& tr, const std::vector<double>& dev) {
  try {
    const double rn = NominalRadiusUm(tr.circular);
    std::vector<Eigen::Vector2d> pts(dev.size());
    for (std::size_t k = 0; k < dev.size(); ++k) {
      pts[k] = (rn + dev[k]) * Eigen::Vector2d(CosAngle(tr.circular, k), SinAngle(tr.circular, k));
    }
    tr.min_zone = geometry::FitMinZoneCircle(
        pts, Eigen::Vector2d(tr.circular.centre_offset_um[0], tr.circular.centre_offset_um[1]));
    tr.min_zone_circularity_um = tr.min_zone.width;
  } catch (const InvalidInput& e) {
    throw InvalidInput(e.file(), e.line(), e.field(), Where(t, i) + ": " + e.reason());
  }
}

void Harmonics(const DbbTest& t, std::size_t i, const DbbAnalysisOptions& opt, DbbTestReport& tr,
               const std::vector<double>& dev) {
  try {
    const CircularTestResult& r = tr.circular;
    std::vector<double> c, s;
    const bool cached = r.cos_angle.size() == dev.size() && r.sin_angle.size() == dev.size();
    for (std::size_t k = 0; !cached && k < dev.size(); ++k) {
      c.push_back(CosAngle(r, k));
      s.push_back(SinAngle(r, k));
    }
    tr.harmonics =
        FitHarmonics(cached ? r.cos_angle : c, cached ? r.sin_angle : s,
                     r.mode == Mode::kAbsolute ? dev : r.radial_error_um,
                     std::min(opt.harmonic_orders, static_cast<int>((dev.size() - 1) / 2)));
  } catch (const InvalidInput& e) {
    throw InvalidInput(e.file(), e.line(), e.field(), Where(t, i) + ": " + e.reason());
  }
}

// Diagnosis of one unit (a single test or a ccw + cw pair).
DiagnosisResult DiagnoseUnit(const std::vector<DbbTest>& tests, const DbbReport& rep,
                             const std::vector<std::vector<double>>& devs,
                             const std::vector<std::size_t>& members,
                             const DbbAnalysisOptions& opt) {
  std::vector<DiagnosisTrace> tr(members.size());
  ParallelFor(
      members.size(),
      [&](std::size_t k) {
        const std::size_t i = members[k];
        tr[k] = MakeDiagnosisTrace(tests[i], rep.tests[i].circular,
                                   BarDeviation(rep.tests[i], devs[i]));
      },
      Threads(opt));
  DiagnosisOptions d = opt.diagnosis;
  if (d.threads == 0) d.threads = opt.threads;
  try {
    return DiagnoseSerialDbb(tr, tests[members.front()].plane, d);
  } catch (const NotObservable& e) {
    DiagnosisResult r;
    r.not_identifiable.push_back(std::string("diagnosis not possible: ") + e.what());
    return r;
  }
}

// A cw and a ccw test with the same test_id: a pair when their figures can be compared (arcs
// that do not overlap are two separate tests). Its diagnosis as a pair runs beside the pair
// figures and counts only when the pair holds.
struct PairCandidate {
  std::string id;
  std::size_t cw = 0, ccw = 0;
  bool same_plane = false;
  std::optional<Iso230PairFigures> iso;
  DiagnosisResult diagnosis;
  std::exception_ptr diagnosis_error;
};

std::vector<PairCandidate> FindPairCandidates(const std::vector<DbbTest>& tests) {
  std::map<std::string, std::vector<std::size_t>> by_id;
  for (std::size_t i = 0; i < tests.size(); ++i) by_id[tests[i].test_id].push_back(i);
  std::vector<PairCandidate> out;
  for (const auto& [id, idx] : by_id) {
    if (idx.size() != 2) continue;
    std::size_t cw = idx[0], ccw = idx[1];
    if (tests[cw].direction == Direction::kCcw) std::swap(cw, ccw);
    if (tests[cw].direction != Direction::kCw || tests[ccw].direction != Direction::kCcw) continue;
    PairCandidate c;
    c.id = id;
    c.cw = cw;
    c.ccw = ccw;
    c.same_plane = tests[cw].plane == tests[ccw].plane;
    out.push_back(std::move(c));
  }
  return out;
}

// The pair figures, the pair diagnoses and the single-test diagnoses, as independent jobs run
// in parallel; the result equals running them in order. Returns the diagnosis units.
std::vector<Unit> PairsAndDiagnoses(const std::vector<DbbTest>& tests, DbbReport& rep,
                                    const std::vector<std::vector<double>>& devs,
                                    const DbbAnalysisOptions& opt) {
  std::vector<PairCandidate> cands = FindPairCandidates(tests);
  std::vector<bool> speculative(tests.size(), false);
  std::vector<std::function<void()>> jobs;  // the longest (diagnoses) first
  std::vector<std::function<void()>> figures;
  for (std::size_t i = 0; i < tests.size(); ++i) {
    figures.emplace_back([&, i] { MinZone(tests[i], i, rep.tests[i], devs[i]); });
    figures.emplace_back([&, i] { Harmonics(tests[i], i, opt, rep.tests[i], devs[i]); });
  }
  for (auto& c : cands) {
    figures.emplace_back([&] {
      try {
        c.iso = ComputeIso230Pair(rep.tests[c.cw].circular, rep.tests[c.ccw].circular, devs[c.cw],
                                  devs[c.ccw], Threads(opt));
      } catch (const InvalidInput&) {
        c.iso.reset();  // partial arcs that do not overlap: two separate tests, not a pair
      }
    });
    if (!opt.diagnose || !c.same_plane) continue;
    speculative[c.cw] = speculative[c.ccw] = true;
    jobs.emplace_back([&] {
      try {
        c.diagnosis = DiagnoseUnit(tests, rep, devs, {c.ccw, c.cw}, opt);
      } catch (...) {
        c.diagnosis_error = std::current_exception();
      }
    });
  }
  std::vector<Unit> singles;
  for (std::size_t i = 0; i < tests.size(); ++i)
    if (opt.diagnose && !speculative[i]) singles.push_back(Unit{{i}, {}});
  for (auto& u : singles)
    jobs.emplace_back([&] { u.result = DiagnoseUnit(tests, rep, devs, u.tests, opt); });
  for (auto& f : figures) jobs.push_back(std::move(f));
  ParallelFor(
      jobs.size(), [&](std::size_t j) { jobs[j](); }, Threads(opt));

  std::vector<Unit> units = std::move(singles);
  for (auto& c : cands) {
    const bool paired = c.iso.has_value();
    if (paired) {
      rep.tests[c.cw].pair = rep.pairs.size();
      rep.tests[c.ccw].pair = rep.pairs.size();
      rep.pairs.push_back(DbbPairReport{c.id, c.cw, c.ccw, *c.iso});
    }
    if (!opt.diagnose || !c.same_plane) continue;
    if (paired) {
      if (c.diagnosis_error) std::rethrow_exception(c.diagnosis_error);
      units.push_back(Unit{{c.ccw, c.cw}, std::move(c.diagnosis)});
    } else {
      for (std::size_t i : {c.cw, c.ccw})
        units.push_back(Unit{{i}, DiagnoseUnit(tests, rep, devs, {i}, opt)});
    }
  }
  std::sort(units.begin(), units.end(),
            [](const Unit& a, const Unit& b) { return a.tests.front() < b.tests.front(); });
  return units;
}

}  // namespace

void DbbAnalysisOptions::Check() const {
  KM_OPTION_GE(harmonic_orders, 1);
  diagnosis.Check();
}

DbbReport AnalyzeDbbSet(const std::vector<DbbTest>& tests, const DbbAnalysisOptions& opt) {
  if (tests.empty()) throw InvalidInput("", 0, "tests", "no DBB test given");
  opt.Check();
  DbbReport rep;
  rep.tests.resize(tests.size());
  std::vector<std::vector<double>> devs(tests.size());  // deviation about the nominal centre
  ParallelFor(
      tests.size(), [&](std::size_t i) { AnalyzeCircle(tests[i], i, rep.tests[i], devs[i]); },
      Threads(opt));
  std::vector<Unit> units = PairsAndDiagnoses(tests, rep, devs, opt);
  if (!opt.diagnose) return rep;
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

}  // namespace km::dbb
