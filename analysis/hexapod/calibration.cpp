#include "analysis/hexapod/calibration.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

#include <Eigen/Dense>

#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"
#include "analysis/hexapod/calibration_cost.h"
#include "analysis/hexapod/dbb_geometry.h"

namespace km::hexapod {

const char* ToString(CalibrationMethod m) {
  return m == CalibrationMethod::kAbsolute ? "absolute" : "centre_corrected";
}

std::string ParameterName(int i) {
  if (i < 6) return "strut_offset_um[" + std::to_string(i) + "]";
  const int j = (i - 6) / 3, c = (i - 6) % 3;
  return "base_joint_offset_um[" + std::to_string(j) + "][" + std::to_string(c) + "]";
}

HexapodGeometry ApplyParameters(const HexapodGeometry& nominal, const ParameterVector& k) {
  HexapodGeometry g = nominal;
  for (int j = 0; j < 6; ++j) {
    g.strut_offset_mm[j] += 1e-3 * k[j];
    for (int c = 0; c < 3; ++c) g.base_joints_mm[j][c] += 1e-3 * k[6 + 3 * j + c];
  }
  return g;
}

ParameterVector ParameterDifference(const HexapodGeometry& nominal, const HexapodGeometry& actual) {
  ParameterVector k;
  for (int j = 0; j < 6; ++j) {
    k[j] = 1000.0 * (actual.strut_offset_mm[j] - nominal.strut_offset_mm[j]);
    for (int c = 0; c < 3; ++c) {
      k[6 + 3 * j + c] = 1000.0 * (actual.base_joints_mm[j][c] - nominal.base_joints_mm[j][c]);
    }
  }
  return k;
}

void CalibrationOptions::Check() const {
  KM_OPTION_GE(max_iterations, 1);
  KM_OPTION_GT(function_tolerance, 0.0);
  KM_OPTION_GT(parameter_tolerance, 0.0);
  KM_OPTION_GT(gradient_tolerance, 0.0);
  KM_OPTION_GT(initial_trust_region_radius, 0.0);
  KM_OPTION_IN_OPEN(rank_tolerance, 0.0, 1.0);
  KM_OPTION_GE(max_samples_per_test, 0);
}

CalibrationProblem BuildCalibrationProblem(const HexapodGeometry& nominal,
                                           const std::vector<dbb::DbbTest>& tests,
                                           const CalibrationOptions& options) {
  options.Check();
  if (tests.empty()) throw InvalidInput("", 0, "tests", "no DBB tests given");
  CalibrationProblem p;
  p.nominal = nominal;
  p.options = options;
  constexpr double kDeg = std::numbers::pi / 180.0;
  for (const auto& t : tests) {
    if (!t.tool_length_mm) {
      throw InvalidInput(t.test_id, 0, "tool_length_mm",
                         "hexapod calibration needs the tool length");
    }
    if (t.angle_deg.size() != t.dr_um.size() || t.angle_deg.size() < 8) {
      throw InvalidInput(t.test_id, 0, "dr_um", "needs at least 8 samples");
    }
    if (!(t.bar_length_mm > 0.0)) {
      throw InvalidInput(t.test_id, 0, "bar_length_mm", "must be positive");
    }
    CalibrationTestData d;
    d.test_id = t.test_id;
    d.direction = t.direction;
    d.tool_length_mm = *t.tool_length_mm;
    if (options.method == CalibrationMethod::kAbsolute) {
      if (!t.fixed_ball_mm) {
        throw InvalidInput(t.test_id, 0, "fixed_ball_mm",
                           "absolute calibration needs the measured fixed-ball position");
      }
      d.fixed_ball_known = true;
      d.fixed_ball_mm =
          Eigen::Vector3d((*t.fixed_ball_mm)[0], (*t.fixed_ball_mm)[1], (*t.fixed_ball_mm)[2]);
    } else {
      d.fixed_ball_known = false;
      d.fixed_ball_mm = Eigen::Vector3d(t.centre_mm[0], t.centre_mm[1], t.centre_mm[2]);
      if (std::abs(t.z_offset_mm) < 1e-6 * t.bar_length_mm) {
        const Eigen::Vector3d n = DbbPlaneAxes(t.plane)[2];
        Eigen::Index axis = 0;
        n.cwiseAbs().maxCoeff(&axis);
        d.ball_fixed_axis = static_cast<int>(axis);
      }
    }
    const std::size_t n = t.angle_deg.size();
    std::size_t stride = 1;
    if (options.max_samples_per_test > 0 &&
        n > static_cast<std::size_t>(options.max_samples_per_test)) {
      stride = (n + options.max_samples_per_test - 1) / options.max_samples_per_test;
    }
    for (std::size_t i = 0; i < n; i += stride) {
      CalibrationSample s;
      s.commanded = CommandedDbbPose(t, t.angle_deg[i] * kDeg);
      s.strut_command_mm = InverseKinematics(nominal, s.commanded, d.tool_length_mm);
      s.measured_bar_mm = t.bar_length_mm + 1e-3 * t.dr_um[i];
      d.samples.push_back(s);
    }
    p.tests.push_back(std::move(d));
  }
  return p;
}

ResidualEvaluation EvaluateResiduals(const CalibrationProblem& problem, const ParameterVector& k_um,
                                     const std::vector<Eigen::Vector3d>& fixed_balls_mm) {
  std::size_t m = 0;
  for (const auto& t : problem.tests) m += t.samples.size();
  ResidualEvaluation ev;
  ev.residual_um.resize(static_cast<Eigen::Index>(m));
  ev.jac_k.resize(static_cast<Eigen::Index>(m), kNumKinematicParameters);
  ev.jac_f.resize(static_cast<Eigen::Index>(m), 3);
  ev.test_of_row.resize(m);
  Eigen::Index row = 0;
  for (std::size_t ti = 0; ti < problem.tests.size(); ++ti) {
    const auto& t = problem.tests[ti];
    for (const auto& s : t.samples) {
      double r = 0.0, dk[kNumKinematicParameters], df[3];
      if (!EvaluateBarSample(problem.nominal, s, t.tool_length_mm, k_um.data(),
                             fixed_balls_mm[ti].data(), &r, dk, df)) {
        throw DidNotConverge("forward kinematics failed for test '" + t.test_id +
                             "': the pose is near a singularity of the candidate machine");
      }
      ev.residual_um[row] = r;
      for (int i = 0; i < kNumKinematicParameters; ++i) ev.jac_k(row, i) = dk[i];
      for (int c = 0; c < 3; ++c) ev.jac_f(row, c) = df[c];
      ev.test_of_row[row] = static_cast<int>(ti);
      ++row;
    }
  }
  return ev;
}

namespace {

// Jacobian w.r.t. K with each test's fixed-ball columns projected out (centre-corrected mode):
// A_t ← (I − J_F,t J_F,t⁺) J_K,t.
Eigen::MatrixXd ProjectedJacobian(const CalibrationProblem& problem, const ResidualEvaluation& ev) {
  Eigen::MatrixXd A = ev.jac_k;
  Eigen::Index row = 0;
  for (const auto& t : problem.tests) {
    const auto n = static_cast<Eigen::Index>(t.samples.size());
    if (!t.fixed_ball_known) {
      Eigen::MatrixXd Jf = ev.jac_f.middleRows(row, n);
      if (t.ball_fixed_axis >= 0) Jf.col(t.ball_fixed_axis).setZero();
      const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Jf);
      const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(n, qr.rank());
      A.middleRows(row, n) -= Q * (Q.transpose() * A.middleRows(row, n));
    }
    row += n;
  }
  return A;
}

// Singular values of A (m×24) via QR then SVD of R, descending; V in `v` if given.
Eigen::VectorXd SingularValues(const Eigen::MatrixXd& A, Eigen::MatrixXd* v) {
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
  const Eigen::Index n = A.cols();
  const Eigen::MatrixXd R =
      qr.matrixQR().topRows(std::min(A.rows(), n)).triangularView<Eigen::Upper>();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(R, Eigen::ComputeFullV);
  if (v) *v = svd.matrixV();
  return svd.singularValues();
}

}  // namespace

void AnalyzeObservability(CalibrationProblem& problem) {
  std::vector<Eigen::Vector3d> balls;
  for (const auto& t : problem.tests) balls.push_back(t.fixed_ball_mm);
  const auto ev = EvaluateResiduals(problem, ParameterVector::Zero(), balls);
  const Eigen::MatrixXd A = ProjectedJacobian(problem, ev);
  Eigen::MatrixXd V;
  const Eigen::VectorXd sv = SingularValues(A, &V);
  problem.singular_values.assign(sv.data(), sv.data() + sv.size());
  problem.fixed.fill(false);
  const double smax = sv.size() ? sv[0] : 0.0;
  if (!(smax > 0.0)) throw NotObservable("the DBB tests carry no information on the parameters");
  int null_dim = 0;
  for (Eigen::Index i = 0; i < sv.size(); ++i) {
    if (sv[i] < problem.options.rank_tolerance * smax) ++null_dim;
  }
  null_dim += static_cast<int>(kNumKinematicParameters - sv.size());
  if (null_dim == 0) return;
  const Eigen::MatrixXd N = V.rightCols(null_dim);  // 24 × k null-space basis
  // Prefer fixing base-joint coordinates ([PM-600 report] §2.2): pivot among them first.
  auto pick = [&](int first) -> std::vector<int> {
    const Eigen::MatrixXd Nt = N.bottomRows(kNumKinematicParameters - first).transpose();
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Nt);
    if (qr.rank() < null_dim) return {};
    std::vector<int> idx;
    for (int i = 0; i < null_dim; ++i) idx.push_back(first + qr.colsPermutation().indices()[i]);
    return idx;
  };
  auto idx = pick(6);
  if (idx.empty()) idx = pick(0);
  if (idx.empty()) throw NotObservable("could not choose parameters to fix the unobservable set");
  for (int i : idx) problem.fixed[i] = true;
}

CalibrationResult Calibrate(const HexapodGeometry& nominal, const std::vector<dbb::DbbTest>& tests,
                            const CalibrationOptions& options) {
  auto problem = BuildCalibrationProblem(nominal, tests, options);
  AnalyzeObservability(problem);
  return SolveCalibration(problem);
}

void internal::FillStatistics(const CalibrationProblem& problem, CalibrationResult& result) {
  const auto ev = EvaluateResiduals(problem, result.parameters_um, result.fixed_balls_mm);
  const Eigen::Index m = ev.residual_um.size();
  result.residual_rms_um = std::sqrt(ev.residual_um.squaredNorm() / static_cast<double>(m));
  std::vector<int> free;
  for (int i = 0; i < kNumKinematicParameters; ++i) {
    if (!problem.fixed[i]) free.push_back(i);
  }
  const Eigen::MatrixXd A = ProjectedJacobian(problem, ev);
  Eigen::MatrixXd Af(m, static_cast<Eigen::Index>(free.size()));
  for (std::size_t c = 0; c < free.size(); ++c)
    Af.col(static_cast<Eigen::Index>(c)) = A.col(free[c]);
  const Eigen::VectorXd sv = SingularValues(Af, nullptr);
  result.condition_number =
      sv[sv.size() - 1] > 0.0 ? sv[0] / sv[sv.size() - 1] : std::numeric_limits<double>::infinity();
  // Covariance of the free parameters: the nuisance parameters are eliminated exactly by the
  // projection (Schur complement), so Cov = σ²·(AfᵀAf)⁻¹, σ² = SSR / (m − n_free − 3·n_free_balls).
  int nuisance = 0;
  for (const auto& t : problem.tests) {
    nuisance += t.fixed_ball_known ? 0 : (t.ball_fixed_axis >= 0 ? 2 : 3);
  }
  const double dof = static_cast<double>(m) - static_cast<double>(free.size()) - nuisance;
  const double sigma2 = dof > 0 ? ev.residual_um.squaredNorm() / dof : 0.0;
  const Eigen::MatrixXd N = Af.transpose() * Af;
  const Eigen::MatrixXd cov =
      sigma2 * N.ldlt().solve(Eigen::MatrixXd::Identity(N.rows(), N.cols()));
  result.uncertainty_um.setZero();
  result.covariance_um2.setZero();
  for (std::size_t c = 0; c < free.size(); ++c) {
    const auto ci = static_cast<Eigen::Index>(c);
    result.uncertainty_um[free[c]] = std::sqrt(std::max(0.0, cov(ci, ci)));
    for (std::size_t d = 0; d < free.size(); ++d) {
      result.covariance_um2(free[c], free[d]) = cov(ci, static_cast<Eigen::Index>(d));
    }
  }
}

std::vector<TestPrediction> PredictAfterCalibration(
    const HexapodGeometry& nominal, const HexapodGeometry& calibrated,
    const std::vector<dbb::DbbTest>& tests, const std::vector<Eigen::Vector3d>& fixed_balls_mm) {
  constexpr double kDeg = std::numbers::pi / 180.0;
  std::vector<TestPrediction> out;
  for (std::size_t ti = 0; ti < tests.size(); ++ti) {
    const auto& t = tests[ti];
    if (!t.tool_length_mm) throw InvalidInput(t.test_id, 0, "tool_length_mm", "missing");
    const double l = *t.tool_length_mm;
    const Eigen::Vector3d centre(t.centre_mm[0], t.centre_mm[1], t.centre_mm[2]);
    // Fixed ball during the measurement (F1) and after calibration (F2).
    Eigen::Vector3d F1, F2;
    if (t.fixed_ball_mm) {
      F1 = F2 =
          Eigen::Vector3d((*t.fixed_ball_mm)[0], (*t.fixed_ball_mm)[1], (*t.fixed_ball_mm)[2]);
    } else {
      F2 = centre;
      if (ti < fixed_balls_mm.size()) {
        F1 = fixed_balls_mm[ti];
      } else {  // conventional set-up under (controller = nominal, real = calibrated)
        const auto n = DbbPlaneAxes(t.plane)[2];
        Pose c = CommandedDbbPose(t, 0.0);
        c.tip_mm = centre + t.z_offset_mm * n;
        const auto fk = ForwardKinematics(calibrated, InverseKinematics(nominal, c, l), l, c);
        F1 = fk.pose.tip_mm - t.z_offset_mm * n;
      }
    }
    TestPrediction p;
    p.test_id = t.test_id;
    p.direction = t.direction;
    p.predicted_dr_um.resize(t.dr_um.size());
    for (std::size_t i = 0; i < t.dr_um.size(); ++i) {
      const Pose cmd = CommandedDbbPose(t, t.angle_deg[i] * kDeg);
      const auto fk1 = ForwardKinematics(calibrated, InverseKinematics(nominal, cmd, l), l, cmd);
      const double f1 = (fk1.pose.tip_mm - F1).norm();
      const double f2 = (cmd.tip_mm - F2).norm();  // FK_K2(IK_K2(T)) = T
      p.predicted_dr_um[i] = t.dr_um[i] + 1000.0 * (f2 - f1);
    }
    const double R = t.radius_mm > 0.0 ? t.radius_mm : t.bar_length_mm;
    p.circularity_before_um = TraceCircleFigures(t.angle_deg, t.dr_um, R).circularity_um;
    p.predicted_circularity_after_um =
        TraceCircleFigures(t.angle_deg, p.predicted_dr_um, R).circularity_um;
    out.push_back(std::move(p));
  }
  return out;
}

std::vector<ReductionStep> TestSetReductionStudy(const HexapodGeometry& nominal,
                                                 const std::vector<dbb::DbbTest>& tests,
                                                 const CalibrationOptions& options, int min_groups,
                                                 const ProgressFn& on_calibration) {
  std::vector<std::string> groups;
  for (const auto& t : tests) {
    if (std::find(groups.begin(), groups.end(), t.test_id) == groups.end())
      groups.push_back(t.test_id);
  }
  if (min_groups < 1) throw InvalidInput("", 0, "min_groups", "must be at least 1");
  std::size_t max_fixed = kNumKinematicParameters;  // set by the full set
  // The calibrations of the study: the full set, then k trials of each set of k groups kept.
  const int n = static_cast<int>(groups.size());
  const int lowest = std::min(std::max(min_groups, 1), n);
  const int total = 1 + (n * (n + 1) - lowest * (lowest + 1)) / 2;
  int done = 0;
  auto evaluate = [&](const std::vector<std::string>& kept, ReductionStep* step) -> bool {
    if (on_calibration) {
      on_calibration(static_cast<double>(done) / total,
                     "calibration " + std::to_string(done + 1) + " of " + std::to_string(total));
    }
    ++done;
    std::vector<dbb::DbbTest> subset;
    for (const auto& t : tests) {
      if (std::find(kept.begin(), kept.end(), t.test_id) != kept.end()) subset.push_back(t);
    }
    CalibrationResult r;
    try {
      r = Calibrate(nominal, subset, options);
    } catch (const NotObservable&) {
      return false;
    } catch (const DidNotConverge&) {
      return false;
    }
    // A subset that loses observability (more parameters fixed than for the full set) ends
    // the study.
    if (r.fixed_parameter_indices.size() > max_fixed) return false;
    // Predict every test (also the dropped ones) with the subset's parameters.
    std::vector<Eigen::Vector3d> balls(tests.size());
    std::vector<Eigen::Vector3d> known;
    std::size_t si = 0;
    bool all = true;
    for (std::size_t i = 0; i < tests.size(); ++i) {
      if (std::find(kept.begin(), kept.end(), tests[i].test_id) != kept.end()) {
        balls[i] = r.fixed_balls_mm[si++];
      } else {
        all = false;
      }
    }
    std::vector<TestPrediction> pred;
    if (all) {
      pred = PredictAfterCalibration(nominal, r.calibrated, tests, balls);
    } else {
      // Per-test prediction so dropped tests use the model-predicted set-up.
      for (std::size_t i = 0; i < tests.size(); ++i) {
        const bool in = std::find(kept.begin(), kept.end(), tests[i].test_id) != kept.end();
        std::vector<Eigen::Vector3d> b;
        if (in) b.push_back(balls[i]);
        auto one = PredictAfterCalibration(nominal, r.calibrated, {tests[i]}, b);
        pred.push_back(one[0]);
      }
    }
    double sum = 0.0, mx = 0.0;
    for (const auto& p : pred) {
      sum += p.predicted_circularity_after_um;
      mx = std::max(mx, p.predicted_circularity_after_um);
    }
    step->groups_kept = static_cast<int>(kept.size());
    step->kept_test_ids = kept;
    step->mean_predicted_circularity_um = sum / static_cast<double>(pred.size());
    step->max_predicted_circularity_um = mx;
    step->condition_number = r.condition_number;
    return true;
  };
  std::vector<ReductionStep> steps;
  ReductionStep full;
  if (!evaluate(groups, &full)) throw NotObservable("the full test set does not calibrate");
  {
    auto probe = BuildCalibrationProblem(nominal, tests, options);
    AnalyzeObservability(probe);
    max_fixed = static_cast<std::size_t>(std::count(probe.fixed.begin(), probe.fixed.end(), true));
  }
  steps.push_back(full);
  std::vector<std::string> kept = groups;
  while (static_cast<int>(kept.size()) > min_groups) {
    ReductionStep best;
    bool found = false;
    for (const auto& drop : kept) {
      std::vector<std::string> trial;
      for (const auto& g : kept) {
        if (g != drop) trial.push_back(g);
      }
      ReductionStep s;
      if (!evaluate(trial, &s)) continue;
      s.dropped_test_id = drop;
      if (!found || s.mean_predicted_circularity_um < best.mean_predicted_circularity_um) {
        best = s;
        found = true;
      }
    }
    if (!found) break;  // no further test can be dropped without losing observability
    kept = best.kept_test_ids;
    steps.push_back(best);
  }
  return steps;
}

}  // namespace km::hexapod
