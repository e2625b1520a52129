// Linear least-squares machinery of the DBB diagnosis (diagnosis.h): candidate effects as
// set-up-free signature columns, the joint fit with rank-revealing selection in list order, the
// covariance with fitted shape parameters, and the conditional gain of one more (sparse) column
// against a fixed base — the cost function of the shape searches (diagnosis_search.h).
// Internal to analysis/dbb.
#pragma once

#include <array>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "analysis/dbb/signatures.h"

namespace km::dbb::diag {

bool IsSpike(serial_effects::EffectId id);
// Effects whose (first) shape parameter the diagnosis fits: spike width, stick-slip period.
bool HasFittedShape(serial_effects::EffectId id);

// Stacked traces (signatures.h) plus the ids handed out to candidate columns (Gram cache keys).
struct Problem : StackedTraces {
  mutable int next_column_id = 0;
};

struct Candidate {
  serial_effects::EffectId id;
  std::vector<double> shape;
  std::vector<Eigen::VectorXd> cols;  // orthogonalised signatures of the linear parameters
  std::vector<int> ids;               // column ids (copies of a candidate share them)
  // Set-up part (cos θ, sin θ, 1 coefficients per trace) removed from each signature.
  std::vector<std::vector<Eigen::Vector3d>> setup_part;
  std::vector<double> raw_norm2;  // squared norm of each signature before the set-up removal
  // Reversal spikes: variance added to the height's for the doubt about the decay shape
  // (diagnosis_search.h ShapeDoubtVariance).
  double shape_doubt_var = 0.0;
  // Reversal spikes: the best width (degrees) of each decay shape (exponential, Gaussian-like)
  // found so far; 0 before a search over the whole range.
  std::array<double, 2> spike_widths{0.0, 0.0};
};

Candidate MakeCandidate(const Problem& p, serial_effects::EffectId id, std::vector<double> shape);
// Several candidates at once, their signatures computed on up to `threads` threads; the column
// ids are given in list order, as MakeCandidate one after another would give them.
struct CandidateSpec {
  serial_effects::EffectId id;
  std::vector<double> shape;
};
std::vector<Candidate> MakeCandidates(const Problem& p, const std::vector<CandidateSpec>& specs,
                                      unsigned threads);

struct FitResult {
  std::vector<int> kept;                  // candidate indices
  std::vector<int> first_col;             // column offset of each kept candidate
  std::vector<std::string> dropped;       // "name (confounded with other)"
  std::vector<const Eigen::VectorXd*> a;  // kept columns (owned by the candidates)
  Eigen::VectorXd x;
  Eigen::MatrixXd cov;
  Eigen::MatrixXd normal;      // AᵀA of the kept columns
  Eigen::MatrixXd normal_inv;  // (AᵀA)⁻¹
  double sigma2 = 0.0;
  int dof = 0;
  Eigen::VectorXd residual;
  // Standard uncertainty of the fitted shape parameter of kept candidate j (index into kept),
  // when the model's jacobian with respect to it was included (AugmentShapes).
  std::map<int, double> shape_sigma;

  // Σ_m x_m a_m over the kept columns [off, off + count).
  Eigen::VectorXd Combine(int off, int count, Eigen::Index n) const;
};

// Inner products already computed, keyed by column ids; valid for one data vector.
struct GramCache {
  std::map<std::pair<int, int>, double> gram;
  std::map<int, double> rhs;
};

// What a fit needs besides the candidates: the set-up-free data and the naming of the plane.
struct FitContext {
  const Problem* p = nullptr;
  const Eigen::VectorXd* e0 = nullptr;
  double confound_ratio = 0.1;
  char first = 'x';
  char second = 'y';
  GramCache* cache = nullptr;
  // Inner products missing from the cache are computed but not added to it (several fits may
  // then share the cache on different threads).
  bool read_only_cache = false;
  unsigned threads = 1;  // for the inner products not yet cached
};

// Joint least-squares fit of the candidates in list order; a candidate whose columns are (almost)
// combinations of earlier ones, or (almost) all set-up, is dropped with the reason.
FitResult Fit(const FitContext& ctx, const std::vector<const Candidate*>& cands);

// Covariance of the full model with the fitted shape parameters included (see diagnosis.cpp).
// The shape derivatives are computed on up to `threads` threads.
void AugmentShapes(const Problem& p, const std::vector<Candidate>& cands, FitResult& f,
                   unsigned threads = 1);

// Base of a conditional fit: the kept columns of a fit (owned by the candidates), their
// (AᵀA)⁻¹ and the residual.
struct Base {
  std::vector<const Eigen::VectorXd*> a;
  Eigen::MatrixXd ninv;
  Eigen::VectorXd r;
  int m = 0;
};
Base MakeBase(const FitResult& f);

// A signature given by its non-zero values BEFORE the set-up is removed.
struct Sparse {
  std::vector<int> idx;
  std::vector<double> val;
  void Clear() {
    idx.clear();
    val.clear();
  }
};

// Residual-sum-of-squares reduction when the set-up-free version of `s` joins the base.
double Gain(const Problem& p, const Base& b, const Sparse& s);

// d s / d (first shape parameter) of a one-linear-parameter candidate at unit value, set-up
// free (diagnosis_fit_ceres.cpp: automatic differentiation of the registry model).
Eigen::VectorXd ShapeDerivative(const Problem& p, const Candidate& c);

// Pointers to the candidates, without the one at index `skip`.
std::vector<const Candidate*> Pointers(const std::vector<Candidate>& cands,
                                       std::size_t skip = static_cast<std::size_t>(-1));

}  // namespace km::dbb::diag
