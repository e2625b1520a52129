#include "analysis/tracker/tracker_sim.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <set>

#include <Eigen/Geometry>

#include "analysis/core/errors.h"
#include "analysis/tracker/volumetric_decomposition.h"

namespace km::tracker {

Eigen::Vector3d MachineErrorModel::ErrorUm(const Eigen::Vector3d& c) const {
  const Eigen::Vector3d p = c - centre_mm;
  Eigen::Vector3d e = 1e-3 * scale_ppm.cwiseProduct(p);
  e.x() -= 1e-3 * squareness_um_per_m(0) * p.y();
  e.y() -= 1e-3 * squareness_um_per_m(1) * p.z();
  e.z() -= 1e-3 * squareness_um_per_m(2) * p.x();
  for (int a = 0; a < 3; ++a) {
    const double t = p(a) / half_range_mm(a);
    for (int dir = 0; dir < 3; ++dir) {
      for (int k = 2; k < 4; ++k) e(dir) += poly_um[a][dir][k] * LegendreP(k, t);
    }
  }
  constexpr double kTwoPi = 6.28318530717958647692;
  for (const auto& w : periodic) {
    if (w.axis < 0 || w.axis > 2 || w.direction < 0 || w.direction > 2 || !(w.period_mm > 0)) {
      throw InvalidInput("", 0, "periodic", "axis and direction 0–2, period > 0 needed");
    }
    e(w.direction) += w.amplitude_um * std::sin(kTwoPi * c(w.axis) / w.period_mm + w.phase_rad);
  }
  return e;
}

TrackerSimResult SimulateTrackerSurvey(const TrackerSimOptions& o) {
  const int m = static_cast<int>(o.commanded_mm.size());
  const int n = static_cast<int>(o.trackers_mm.size());
  if (m < 1 || n < 1) throw InvalidInput("", 0, "trackers_mm", "need points and trackers");
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::bernoulli_distribution sign_of_shift(0.5);
  TrackerSimResult out;
  auto& r = out.readings;
  r.machine_id = "sim";
  r.mode = o.mode;
  r.commanded_mm = o.commanded_mm;
  r.point_ids.resize(static_cast<std::size_t>(m));
  std::iota(r.point_ids.begin(), r.point_ids.end(), 1);
  r.beam_breaks = o.beam_breaks;
  for (int i = 0; i < m; ++i) {
    const auto& c = o.commanded_mm[static_cast<std::size_t>(i)];
    out.true_points_mm.push_back(c + 1e-3 * o.machine.ErrorUm(c));
  }
  r.displacement_um.resize(m, n);
  for (int j = 0; j < n; ++j) {
    std::vector<std::size_t> starts{0};
    for (const auto& b : o.beam_breaks) {
      if (b.tracker == j) starts.push_back(b.row);
    }
    std::sort(starts.begin(), starts.end());
    // A break re-zeroed elsewhere: the new zero is a place 20–100 mm nearer or farther than the
    // break's point (its reading there is not 0).
    std::vector<double> shift_um(static_cast<std::size_t>(m), 0.0);
    for (const auto& b : o.beam_breaks) {
      if (b.tracker != j || !b.elsewhere || b.row >= static_cast<std::size_t>(m)) continue;
      std::uniform_real_distribution<double> mm(20.0, 100.0);
      shift_um[b.row] = 1e3 * mm(rng) * (sign_of_shift(rng) ? 1.0 : -1.0);
    }
    // Distances (µm) to where the target stands at each visit, and the noise of each reading.
    std::vector<double> dist(static_cast<std::size_t>(m)), noise(static_cast<std::size_t>(m));
    for (int i = 0; i < m; ++i) {
      Eigen::Vector3d u = out.true_points_mm[static_cast<std::size_t>(i)];
      if (o.mode == TrackerMode::kSequential && o.repeatability_um > 0) {
        u += 1e-3 * o.repeatability_um * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
      }
      dist[static_cast<std::size_t>(i)] =
          1e3 * (u - o.trackers_mm[static_cast<std::size_t>(j)]).norm();
      noise[static_cast<std::size_t>(i)] = o.noise_um * gauss(rng);
    }
    for (int i = 0; i < m; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      const auto it = std::upper_bound(starts.begin(), starts.end(), ui);
      const std::size_t ref = *(it - 1);
      // The zero is exact: the counter is reset where the target stands (shift_um: elsewhere).
      const bool zero = ui == ref && shift_um[ref] == 0.0;
      r.displacement_um(i, j) = zero ? 0.0 : dist[ui] + noise[ui] - dist[ref] - shift_um[ref];
    }
  }
  const int count = static_cast<int>(std::lround(o.outlier_fraction * m * n));
  std::set<std::pair<int, int>> chosen;
  std::uniform_int_distribution<int> pick_i(1, std::max(1, m - 1)), pick_j(0, n - 1);
  std::bernoulli_distribution sign(0.5);
  while (static_cast<int>(chosen.size()) < count && m > 1) {
    const std::pair<int, int> key{pick_i(rng), pick_j(rng)};
    bool is_ref = false;
    for (const auto& b : o.beam_breaks) {
      is_ref |= b.tracker == key.second && static_cast<int>(b.row) == key.first;
    }
    if (is_ref || !chosen.insert(key).second) continue;
    r.displacement_um(key.first, key.second) += sign(rng) ? o.outlier_um : -o.outlier_um;
  }
  out.outliers.assign(chosen.begin(), chosen.end());
  return out;
}

std::vector<Eigen::Vector3d> GridPoints(const Eigen::Vector3d& centre_mm, double size_mm,
                                        int per_axis) {
  std::vector<Eigen::Vector3d> out;
  const double step = per_axis > 1 ? size_mm / (per_axis - 1) : 0.0;
  const double h = per_axis > 1 ? size_mm / 2 : 0.0;
  for (int k = 0; k < per_axis; ++k) {
    for (int j = 0; j < per_axis; ++j) {
      for (int i = 0; i < per_axis; ++i) {
        out.push_back(centre_mm + Eigen::Vector3d(i * step - h, j * step - h, k * step - h));
      }
    }
  }
  return out;
}

std::vector<Eigen::Vector3d> PlaceTrackers(const Eigen::Vector3d& centre_mm, int n, double min_mm,
                                           double max_mm, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> dist(min_mm, max_mm), jitter(-0.2, 0.2), low(-45.0, -20.0),
      high(-5.0, 15.0);
  constexpr double kPi = 3.14159265358979323846;
  for (int attempt = 0; attempt < 100; ++attempt) {
    std::vector<Eigen::Vector3d> out;
    for (int j = 0; j < n; ++j) {
      const double az = 2 * kPi * (j + 0.5 + jitter(rng)) / n;
      // Alternating low and high stations spread the vertical directions (better z precision).
      const double el = (j % 2 == 0 ? low(rng) : high(rng)) * kPi / 180.0;
      const double d = dist(rng);
      out.push_back(centre_mm + d * Eigen::Vector3d(std::cos(el) * std::cos(az),
                                                    std::cos(el) * std::sin(az), std::sin(el)));
    }
    if (n < 4) return out;
    // Tracker 4 well off the plane of 1–3 (the gauge needs it).
    const Eigen::Vector3d nrm = (out[1] - out[0]).cross(out[2] - out[0]).normalized();
    if (std::abs(nrm.dot(out[3] - out[0])) > 0.15 * min_mm) return out;
  }
  throw InvalidInput("", 0, "trackers", "could not place non-coplanar trackers");
}

}  // namespace km::tracker
