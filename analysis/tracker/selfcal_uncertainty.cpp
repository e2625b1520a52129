// Monte Carlo propagation of the ranging readings' uncertainty through the self-calibration's
// own least-squares solve (selfcal_uncertainty.h, docs/methods.md §16.5).
#include "analysis/tracker/selfcal_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>

#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"
#include "analysis/tracker/selfcal_solver.h"
#include "analysis/tracker/tracker_selfcal_stages.h"

namespace km::tracker {
namespace {

constexpr double kNoValue = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kAxisName[3] = {"x", "y", "z"};

// The figures of one solved state, in the order of RangingUncertainty's outputs.
class FigureMaker {
 public:
  FigureMaker(const TrackerReadings& readings, const SelfCalProblem& problem)
      : readings_(readings),
        problem_(problem),
        use_(problem.PointsInUse()),
        segments_(problem.SegmentsInUse()) {}

  // The figure keys and, per figure, the tracker and axis of its least-squares σ (−1: none).
  void Describe(RangingUncertainty& out) const {
    out.figure_keys = {"volumetric_error_max_um", "residual_rms_um"};
    out.figure_tracker = {-1, -1};
    out.figure_axis = {-1, -1};
    for (int j = 0; j < problem_.num_trackers; ++j) {
      for (int a = 0; a < FreeAxes(j); ++a) {
        out.figure_keys.push_back("trackers_mm[" + std::to_string(j) + "]." + kAxisName[a]);
        out.figure_tracker.push_back(j);
        out.figure_axis.push_back(a);
      }
    }
    for (std::size_t s = 0; s < segments_.size(); ++s) {
      if (!segments_[s]) continue;
      out.figure_keys.push_back("dead_paths[" + std::to_string(s) + "].dead_path_mm");
      out.figure_tracker.push_back(-1);
      out.figure_axis.push_back(-1);
    }
    out.point_output.assign(use_.size(), -1);
    int next = static_cast<int>(out.figure_keys.size());
    for (std::size_t i = 0; i < use_.size(); ++i) {
      if (use_[i]) {
        out.point_output[i] = next;
        next += 3;
      }
    }
  }

  std::size_t NumOutputs() const {
    std::size_t n = 2 + std::count(segments_.begin(), segments_.end(), char{1}) +
                    3 * static_cast<std::size_t>(std::count(use_.begin(), use_.end(), char{1}));
    for (int j = 0; j < problem_.num_trackers; ++j) n += static_cast<std::size_t>(FreeAxes(j));
    return n;
  }

  void Evaluate(const SelfCalState& state, std::span<double> y) const {
    const RigidTransform T = FitRigid(state.points_mm, readings_.commanded_mm, &use_);
    std::size_t k = 2;
    for (int j = 0; j < problem_.num_trackers; ++j) {
      for (int a = 0; a < FreeAxes(j); ++a) {
        y[k++] = 1e3 * state.trackers_mm[static_cast<std::size_t>(j)](a);
      }
    }
    const auto zero = problem_.ZeroLengthsMm(state);
    for (std::size_t s = 0; s < segments_.size(); ++s) {
      if (segments_[s]) y[k++] = 1e3 * zero[s];
    }
    double largest = 0.0;
    for (std::size_t i = 0; i < use_.size(); ++i) {
      if (!use_[i]) continue;
      const Eigen::Vector3d e = 1e3 * (T.Apply(state.points_mm[i]) - readings_.commanded_mm[i]);
      largest = std::max(largest, e.norm());
      for (int a = 0; a < 3; ++a) y[k++] = e(a);
    }
    y[0] = largest;
    double ssr = 0.0;
    for (double r : problem_.ResidualsUm(state)) {
      if (std::isfinite(r)) ssr += r * r;
    }
    y[1] = std::sqrt(ssr / static_cast<double>(std::max<std::size_t>(problem_.NumActive(), 1)));
  }

 private:
  // The gauge fixes tracker 1, y and z of tracker 2, z of tracker 3: free are x of tracker 2,
  // x and y of tracker 3, all of the others.
  static int FreeAxes(int tracker) { return std::min(tracker, 3); }

  const TrackerReadings& readings_;
  const SelfCalProblem& problem_;
  std::vector<char> use_;
  std::vector<char> segments_;
};

}  // namespace

double VolumetricErrorMaxUm(const SelfCalResult& result) {
  double largest = kNoValue;
  for (std::size_t i = 0; i < result.volumetric_error_um.size(); ++i) {
    const Eigen::Vector3d& e = result.volumetric_error_um[i];
    if (!e.allFinite()) continue;
    largest = std::isnan(largest) ? e.norm() : std::max(largest, e.norm());
  }
  return largest;
}

void RangingUncertaintyOptions::Check() const {
  KM_OPTION_GE(draws, 20u);
}

RangingUncertainty PropagateRangingUncertainty(const TrackerReadings& readings,
                                               const SelfCalResult& result,
                                               const SelfCalSolution& solution, double u_ranging_um,
                                               const RangingUncertaintyOptions& options) {
  options.Check();
  if (!(u_ranging_um > 0.0 && std::isfinite(u_ranging_um))) {
    throw InvalidInput("", 0, "u_ranging_um", "must be a finite number > 0 to be propagated");
  }
  const SelfCalProblem& base = solution.problem;
  std::vector<std::size_t> drawn;  // the observations in use
  for (std::size_t k = 0; k < base.observations.size(); ++k) {
    if (base.active[k]) drawn.push_back(k);
  }
  if (drawn.empty()) throw InvalidInput("", 0, "readings", "no reading in use");
  RangingUncertainty out;
  out.readings = drawn.size();
  const FigureMaker figures(readings, base);
  figures.Describe(out);
  const std::size_t outputs = figures.NumOutputs();

  // The base values, and the first-order u from u²·(JᵀJ)⁻¹ of the same problem.
  std::vector<double> y0(outputs);
  figures.Evaluate(solution.state, y0);
  out.figure_value_um.assign(y0.begin(),
                             y0.begin() + static_cast<std::ptrdiff_t>(out.figure_keys.size()));
  out.u_gum_um.assign(outputs, kNoValue);
  const SelfCalCovariance cov = ComputeCovariance(base, solution.state, u_ranging_um);
  for (std::size_t f = 0; f < out.figure_keys.size(); ++f) {
    const int j = out.figure_tracker[f];
    if (j >= 0 && static_cast<std::size_t>(j) < cov.tracker_um2.size()) {
      out.u_gum_um[f] = std::sqrt(std::max(
          cov.tracker_um2[static_cast<std::size_t>(j)](out.figure_axis[f], out.figure_axis[f]),
          0.0));
    }
  }
  const Eigen::Matrix3d& R = result.gauge_to_commanded.rotation;
  for (std::size_t i = 0; i < out.point_output.size(); ++i) {
    if (out.point_output[i] < 0 || i >= cov.point_free_um2.size()) continue;
    const Eigen::Matrix3d C = R * cov.point_free_um2[i] * R.transpose();
    for (int a = 0; a < 3; ++a) {
      out.u_gum_um[static_cast<std::size_t>(out.point_output[i] + a)] =
          std::sqrt(std::max(C(a, a), 0.0));
    }
  }

  // Each draw: the readings in use plus their noise, re-solved from the base solution.
  SelfCalProblem problem = base;
  SelfCalState state;
  SolveOptions sopt = solution.solve;
  sopt.cauchy_scale_um = 0.0;
  sopt.refine_steps = true;
  const uncertainty::VectorModel model = [&](std::span<const double> x, std::span<double> y) {
    for (std::size_t g = 0; g < drawn.size(); ++g) {
      problem.observations[drawn[g]].d_mm = base.observations[drawn[g]].d_mm + 1e-3 * x[g];
    }
    state = solution.state;
    SolveReport rep = SolveSelfCal(problem, sopt, state);
    for (int extra = 0; extra < 2 && !rep.converged && std::isfinite(rep.final_cost); ++extra) {
      rep = SolveSelfCal(problem, sopt, state);
    }
    if (!std::isfinite(rep.final_cost)) {
      throw DidNotConverge(
          "laser-tracker uncertainty: a Monte Carlo draw of the readings did not "
          "solve (" +
          rep.message + ")");
    }
    selfcal_stages::FixGaugeSign(state);
    figures.Evaluate(state, y);
  };
  uncertainty::McOptions mo;
  mo.draws = options.draws;
  mo.seed = options.seed;
  mo.budget_draws = 0;  // one input: its contribution is u itself
  out.mc = uncertainty::PropagateMonteCarlo(
      model, {uncertainty::McInput::NormalGroup("u_ranging_um", 0.0, u_ranging_um, drawn.size())},
      outputs, mo);
  for (auto& o : out.mc.outputs) o.budget = {o.u};
  return out;
}

}  // namespace km::tracker
