#include "analysis/tracker/selfcal_problem.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/SVD>

#include "analysis/core/errors.h"

namespace km::tracker {

const char* ModeName(TrackerMode mode) {
  return mode == TrackerMode::kSequential ? "sequential" : "simultaneous";
}

namespace {

// The reading where an interferometer was zeroed is 0. One that is 0 to 1 nm (files carry
// 0.1 nm) or missing says nothing more; one within 10 µm of 0 is a zero whose reading carries
// noise (not used: eq. 1 has it 0); one farther from 0 cannot have been read where the
// interferometer was zeroed: its zero was elsewhere (a dead path).
constexpr double kZeroReadingUm = 1e-3;
constexpr double kNotZeroedThereUm = 10.0;

// The zero of the segment of `tracker` starting at `row` (0, or a beam break without
// `elsewhere`): that row, or −1 (elsewhere); a note when the reading there is not 0.
int ZeroOf(const TrackerReadings& readings, int tracker, std::size_t row,
           std::vector<std::string>& notes) {
  const double d = readings.displacement_um(static_cast<long>(row), tracker);
  if (!std::isfinite(d) || std::abs(d) <= kZeroReadingUm) return static_cast<int>(row);
  const int id = readings.point_ids[row];
  std::ostringstream os;
  os << "tracker " << tracker + 1 << " reads " << d << " um at point " << id << ", where "
     << (row == 0 ? "its readings start (the first point)"
                  : "its beam break says it was re-zeroed");
  if (std::abs(d) <= kNotZeroedThereUm) {
    os << ": eq. (1) has that reading 0, and it is not used";
    notes.push_back(os.str());
    return static_cast<int>(row);
  }
  os << ": a reading there would be 0, so it was taken as zeroed elsewhere (an unknown dead "
        "path for its readings from that point on)";
  if (row > 0) {
    os << "; write '# beam_break: " << tracker + 1 << ", " << id << ", elsewhere' to say so";
  }
  notes.push_back(os.str());
  return -1;
}

}  // namespace

SelfCalProblem SelfCalProblem::FromReadings(const TrackerReadings& readings) {
  SelfCalProblem p;
  p.num_points = readings.NumPoints();
  p.num_trackers = readings.NumTrackers();
  if (readings.displacement_um.rows() != p.num_points ||
      readings.point_ids.size() != static_cast<std::size_t>(p.num_points)) {
    throw InvalidInput("", 0, "displacement_um",
                       "one point id and one row of readings per commanded point needed");
  }
  // Segments per tracker: from row 0 (zeroed at point 1, [Tracker paper] eq. 1) and from every
  // beam break, in row order.
  std::vector<std::vector<Segment>> per(static_cast<std::size_t>(p.num_trackers));
  for (int j = 0; j < p.num_trackers; ++j) per[static_cast<std::size_t>(j)].push_back({j, 0, 0});
  std::vector<char> first_elsewhere(static_cast<std::size_t>(p.num_trackers), 0);
  for (const auto& b : readings.beam_breaks) {
    if (b.tracker < 0 || b.tracker >= p.num_trackers) {
      throw InvalidInput("", 0, "beam_break",
                         "tracker " + std::to_string(b.tracker + 1) + " does not exist");
    }
    if (b.row >= static_cast<std::size_t>(p.num_points)) {
      throw InvalidInput("", 0, "beam_break", "row " + std::to_string(b.row) + " out of range");
    }
    auto& segs = per[static_cast<std::size_t>(b.tracker)];
    const int row = static_cast<int>(b.row);
    const auto same = std::find_if(segs.begin(), segs.end(),
                                   [&](const Segment& s) { return s.start_row == row; });
    if (same == segs.end()) {
      segs.push_back(
          {b.tracker, row, b.elsewhere ? -1 : ZeroOf(readings, b.tracker, b.row, p.notes)});
    } else if (b.elsewhere) {
      same->zero_point = -1;  // a break at the first row: zeroed elsewhere from the start
      if (row == 0) first_elsewhere[static_cast<std::size_t>(b.tracker)] = 1;
    }
  }
  // Point 1: every tracker's zero ([Tracker paper] eq. 1), unless its reading there says not.
  for (int j = 0; j < p.num_trackers && p.num_points > 0; ++j) {
    if (first_elsewhere[static_cast<std::size_t>(j)]) continue;
    per[static_cast<std::size_t>(j)].front().zero_point = ZeroOf(readings, j, 0, p.notes);
  }
  std::vector<std::vector<int>> ids(per.size());
  for (auto& segs : per) {
    std::sort(segs.begin(), segs.end(),
              [](const Segment& a, const Segment& b) { return a.start_row < b.start_row; });
    for (const auto& s : segs) {
      ids[static_cast<std::size_t>(s.tracker)].push_back(static_cast<int>(p.segments.size()));
      p.segments.push_back(s);
    }
  }
  for (int i = 0; i < p.num_points; ++i) {
    for (int j = 0; j < p.num_trackers; ++j) {
      const double d = readings.displacement_um(i, j);
      if (!std::isfinite(d)) continue;
      const auto& segs = per[static_cast<std::size_t>(j)];
      std::size_t k = 0;
      while (k + 1 < segs.size() && segs[k + 1].start_row <= i) ++k;
      if (segs[k].zero_point == i) continue;  // the zero reading: 0 by definition
      p.observations.push_back({i, j, ids[static_cast<std::size_t>(j)][k], d * 1e-3});
    }
  }
  p.active.assign(p.observations.size(), 1);
  return p;
}

std::vector<char> SelfCalProblem::SegmentsInUse() const {
  std::vector<char> use(segments.size(), 0);
  for (std::size_t k = 0; k < observations.size(); ++k) {
    if (active[k]) use[static_cast<std::size_t>(observations[k].segment)] = 1;
  }
  return use;
}

std::vector<char> SelfCalProblem::PointsInUse() const {
  std::vector<char> use(static_cast<std::size_t>(num_points), 0);
  for (std::size_t k = 0; k < observations.size(); ++k) {
    if (!active[k]) continue;
    const auto& o = observations[k];
    use[static_cast<std::size_t>(o.point)] = 1;
    const int z = segments[static_cast<std::size_t>(o.segment)].zero_point;
    if (z >= 0) use[static_cast<std::size_t>(z)] = 1;
  }
  return use;
}

std::size_t SelfCalProblem::NumActive() const {
  return static_cast<std::size_t>(std::count(active.begin(), active.end(), 1));
}

std::size_t SelfCalProblem::NumUnknowns() const {
  const auto use = PointsInUse();
  const auto seg = SegmentsInUse();
  std::size_t free = 0;
  for (std::size_t s = 0; s < segments.size(); ++s) free += seg[s] && segments[s].FreeDeadPath();
  const auto points = static_cast<std::size_t>(std::count(use.begin(), use.end(), 1));
  const auto n = static_cast<std::size_t>(num_trackers);
  return 3 * points + (n >= 2 ? 3 * n - 6 + (n == 2 ? 1 : 0) : 0) + free;
}

void SelfCalProblem::CheckCounting() const {
  const auto use = PointsInUse();
  const auto m = std::count(use.begin(), use.end(), 1);
  const auto n = num_trackers;
  int z = 0, f = 0;
  for (const auto& s : segments) {
    if (s.start_row == 0) continue;
    (s.FreeDeadPath() ? f : z) += 1;
  }
  const auto readings = NumActive();
  const auto unknowns = NumUnknowns();
  if (n < 4 || readings < unknowns) {
    std::ostringstream os;
    os << "laser-tracker self-calibration is not observable: the readings must satisfy "
          "n·(m − 1)"
       << (z > 0 ? " − z" : "") << " ≥ 3m + 3n − 6" << (f > 0 ? " + f" : "")
       << " (m points, n trackers each zeroed at point 1, [Tracker paper] eq. 1"
       << (z > 0 ? "; z beam breaks re-zeroed at a point" : "")
       << (f > 0 ? "; f beam breaks re-zeroed elsewhere, each an unknown dead path" : "")
       << "); here m = " << m << ", n = " << n;
    if (z > 0) os << ", z = " << z;
    if (f > 0) os << ", f = " << f;
    os << ": " << readings << " readings < " << unknowns << " unknowns";
    if (n < 4) os << " (at least 4 trackers are needed)";
    throw NotObservable(os.str());
  }
  // Trackers that see each point: its readings, and the segments zeroed at it.
  std::vector<std::vector<char>> seen(static_cast<std::size_t>(num_points),
                                      std::vector<char>(static_cast<std::size_t>(n), 0));
  for (std::size_t k = 0; k < observations.size(); ++k) {
    if (!active[k]) continue;
    const auto& o = observations[k];
    const auto j = static_cast<std::size_t>(o.tracker);
    seen[static_cast<std::size_t>(o.point)][j] = 1;
    const int zp = segments[static_cast<std::size_t>(o.segment)].zero_point;
    if (zp >= 0) seen[static_cast<std::size_t>(zp)][j] = 1;
  }
  for (int i = 0; i < num_points; ++i) {
    const auto& v = seen[static_cast<std::size_t>(i)];
    const auto c = std::count(v.begin(), v.end(), 1);
    if (c > 0 && c < 3) {
      throw NotObservable("laser-tracker self-calibration: point row " + std::to_string(i + 1) +
                          " is seen by only " + std::to_string(c) +
                          " trackers; a point needs at least 3");
    }
  }
}

std::vector<double> SelfCalProblem::ZeroLengthsMm(const SelfCalState& state) const {
  std::vector<double> z(segments.size(), 0.0);
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const Segment& g = segments[s];
    z[s] = g.FreeDeadPath() ? state.offsets_mm[s]
                            : (state.points_mm[static_cast<std::size_t>(g.zero_point)] -
                               state.trackers_mm[static_cast<std::size_t>(g.tracker)])
                                  .norm();
  }
  return z;
}

void SelfCalProblem::UpdateZeroLengths(SelfCalState& state) const {
  state.offsets_mm.resize(segments.size(), 0.0);
  state.offsets_mm = ZeroLengthsMm(state);
}

std::vector<double> SelfCalProblem::ResidualsUm(const SelfCalState& s) const {
  const std::vector<double> z = ZeroLengthsMm(s);
  std::vector<double> r(observations.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < observations.size(); ++k) {
    if (!active[k]) continue;
    const auto& o = observations[k];
    const double rho = (s.points_mm[static_cast<std::size_t>(o.point)] -
                        s.trackers_mm[static_cast<std::size_t>(o.tracker)])
                           .norm();
    r[k] = 1e3 * (rho - z[static_cast<std::size_t>(o.segment)] - o.d_mm);
  }
  return r;
}

RigidTransform GaugeTransform(const std::vector<Eigen::Vector3d>& U) {
  if (U.size() < 3) throw NotObservable("the gauge needs at least 3 trackers");
  const Eigen::Vector3d a = U[1] - U[0];
  if (a.norm() < 1e-6) throw NotObservable("trackers 1 and 2 coincide; the gauge is undefined");
  const Eigen::Vector3d ex = a.normalized();
  Eigen::Vector3d v = U[2] - U[0];
  Eigen::Vector3d ey = v - v.dot(ex) * ex;
  if (ey.norm() < 1e-6 * std::max(1.0, v.norm())) {
    throw NotObservable(
        "trackers 1, 2 and 3 are collinear; the gauge (3 in the xy-plane) is "
        "undefined");
  }
  ey.normalize();
  Eigen::Vector3d ez = ex.cross(ey);
  RigidTransform T;
  if (U.size() >= 4 && ez.dot(U[3] - U[0]) < 0) {
    ez = -ez;
    T.mirrored = true;
  }
  T.rotation.row(0) = ex.transpose();
  T.rotation.row(1) = ey.transpose();
  T.rotation.row(2) = ez.transpose();
  T.translation_mm = -T.rotation * U[0];
  return T;
}

RigidTransform FitRigid(const std::vector<Eigen::Vector3d>& from,
                        const std::vector<Eigen::Vector3d>& to, const std::vector<char>* use) {
  if (to.size() != from.size() || (use && use->size() != from.size())) {
    throw InvalidInput("", 0, "points", "a rigid fit needs as many target points as points");
  }
  Eigen::Vector3d cf = Eigen::Vector3d::Zero(), ct = Eigen::Vector3d::Zero();
  double w = 0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (use && !(*use)[i]) continue;
    cf += from[i];
    ct += to[i];
    w += 1;
  }
  if (w < 3) throw NotObservable("a rigid fit needs at least 3 points");
  cf /= w;
  ct /= w;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (use && !(*use)[i]) continue;
    H += (from[i] - cf) * (to[i] - ct).transpose();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixV() * svd.matrixU().transpose();
  RigidTransform T;
  if (R.determinant() < 0) {
    const auto& s = svd.singularValues();
    if (s(2) > 1e-9 * s(0)) {
      T.mirrored = true;  // the mirror image fits better: keep it (distances cannot tell)
    } else {
      Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
      D(2, 2) = -1;
      R = svd.matrixV() * D * svd.matrixU().transpose();
    }
  }
  T.rotation = R;
  T.translation_mm = ct - R * cf;
  return T;
}

}  // namespace km::tracker
