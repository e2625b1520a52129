// The run of one serial-machine diagnosis (diagnosis.h), shared by its source files:
// diagnosis.cpp (the stages, spikes, shapes, naming) and diagnosis_periodic.cpp (stick-slip and
// cyclic errors). Internal to the diagnosis.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/dbb/diagnosis_fit.h"
#include "analysis/dbb/diagnosis_search.h"
#include "analysis/dbb/diagnosis_types.h"

namespace km::dbb::diag {

using Eigen::VectorXd;
using serial_effects::EffectId;

// Smallest radius (mm) and largest angular step (rad) of the traces.
struct Spacing {
  double rmin = 1e300;
  double max_step = 0.0;
};
inline Spacing TraceSpacing(const std::vector<DiagnosisTrace>& traces) {
  Spacing s;
  for (const auto& tr : traces) {
    s.rmin = std::min(s.rmin, tr.radius_mm);
    for (std::size_t i = 1; i < tr.angle_rad.size(); ++i)
      s.max_step = std::max(s.max_step, std::abs(tr.angle_rad[i] - tr.angle_rad[i - 1]));
  }
  return s;
}

// One diagnosis: the set-up fit, then the stages in order, each adding candidates or refining
// their shapes against the fit of the others (see diagnosis.h for the model).
class DiagnosisRun {
 public:
  DiagnosisRun(const std::vector<DiagnosisTrace>& traces, Plane plane, const DiagnosisOptions& opt);
  DiagnosisRun(const DiagnosisRun&) = delete;
  DiagnosisRun& operator=(const DiagnosisRun&) = delete;
  DiagnosisResult Run();

 private:
  FitResult FitAll(const std::vector<Candidate>& c) const { return Fit(ctx_, Pointers(c)); }
  void AddSpikes(const FitResult& f1);
  void AddStickSlipAndCyclicErrors(FitResult& f2);
  bool StickSlipAssessed();
  double StickSlipPeak(const FitResult& f2, double* chi2) const;
  bool AddStickSlip(FitResult& f2, double peak, double chi2);
  double CyclicPeriod(const FitResult& f2, int axis) const;
  void AddCyclicErrors(const std::array<double, 2>& found);
  void RefineCyclicPeriods(FitResult& f3);
  void RefineShapes(FitResult& f3);
  struct Refined {
    std::optional<std::vector<double>> shape;      // none: unchanged
    double shape_doubt_var = 0.0;                  // spikes: Candidate::shape_doubt_var
    std::array<double, 2> spike_widths{0.0, 0.0};  // spikes: Candidate::spike_widths
  };
  Refined RefinedShape(const FitContext& ctx, const std::vector<Candidate>& cands, std::size_t q,
                       bool near_known = false) const;
  void RefineNamedSpikes(std::vector<Candidate>& chosen);
  std::vector<Candidate> Screen(const FitResult& f3, DiagnosisResult& res);
  bool SpikeResolved(const Candidate& c) const;
  VectorXd NameEffects(const std::vector<Candidate>& chosen, const FitResult& f4,
                       DiagnosisResult& res);
  DiagnosisEntry SetupEntry(EffectId id, std::vector<double> value,
                            std::vector<double> sigma) const;
  void AddSetupEntries(const FitResult& f4, DiagnosisResult& res) const;
  void RankNamed(const VectorXd& final_res, DiagnosisResult& res) const;

  const std::vector<DiagnosisTrace>& traces_;
  const DiagnosisOptions& opt_;
  char first_ = 'x';
  char second_ = 'y';
  Problem p_;
  VectorXd e0_;                         // data without the set-up terms
  std::vector<Eigen::Vector3d> setup_;  // set-up terms per trace (centre u, v, radius)
  GramCache cache_;
  FitContext ctx_;
  double median_step_ = 0.0;
  unsigned threads_ = 1;
  double spike_lo_ = 0.0;
  double spike_hi_ = 0.0;
  std::vector<ReversalOrder> order_;  // per axis, when spikes are assessed
  StickZones zones_;
  Sparse buf_;
  std::vector<Candidate> cands_;
  std::vector<std::string> not_assessed_;
};

}  // namespace km::dbb::diag
