// Entries of the DBB diagnosis (diagnosis.h): the reported value, uncertainty and shape of a
// fitted candidate (for reversal spikes also the decay shape, the width in seconds and the doubt
// about the decay shape), the contributions to the circularity and the naming rule. Internal to
// analysis/dbb.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "analysis/dbb/diagnosis_fit.h"
#include "analysis/dbb/diagnosis_types.h"

namespace km::dbb::diag {

// |value| / σ, finite also for noise-free data (σ = 0).
double ZScore(double value, double sigma);

// A reversal spike's decay shape, width in time and shape doubt added to `en` (see the .cpp).
void AddSpikeFigures(const Problem& p, const Candidate& c, DiagnosisEntry& en);

// Entry of kept candidate j of the fit f: value, uncertainty, shape, peak-to-valley per trace.
DiagnosisEntry MakeEntry(const Problem& p, const Candidate& c, const FitResult& f, std::size_t j,
                         char first, char second);

// contribution_pct of each entry on every trace: its own peak-to-valley over the sum of all the
// entries' peak-to-valley values plus the range of what is left unexplained.
void Normalise(const Problem& p, std::vector<DiagnosisEntry*> entries,
               const Eigen::VectorXd& residual);

// Whether an entry is named by its significance (diagnosis.h: z, or z + 1 for two values and
// searched shapes; a reversed stick-slip sawtooth never).
bool Significant(const DiagnosisEntry& e, const DiagnosisOptions& o);

}  // namespace km::dbb::diag
