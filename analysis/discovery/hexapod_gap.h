// What the gap of a hexapod model shows, in figures and in sentences computed from them
// (analysis/discovery/hexapod_family.h): its parts alike and opposite in CW and CCW (pairs of
// one test_id matched at the same angle), what its size per test follows (tilt, time, strut
// length, fixed-ball height, tool), its harmonic content over the circle, and the repeatability
// floor — the σ of what the CW and CCW runs of a test do not share.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "analysis/hexapod/effect_fit.h"

namespace km::discovery {

// Pearson correlation (0 with fewer than 3 values or no spread); RMS of rows [r0, r1).
double Correlation(const std::vector<double>& a, const std::vector<double>& b);
double SegmentRms(const Eigen::VectorXd& v, int r0, int r1);

// Rows of CW/CCW partners at the same angle (nearest sample), for every complete pair.
class PairedRows {
 public:
  explicit PairedRows(const hexapod::EffectFitData& data);
  const std::vector<std::pair<int, int>>& Rows() const { return rows_; }
  // Mean squares of the half-sum (even part) and the half-difference (odd part) of `v`.
  std::pair<double, double> EvenOdd(const Eigen::VectorXd& v) const;

 private:
  std::vector<std::pair<int, int>> rows_;
};

struct GapFigures {
  std::map<std::string, double> figures;
  std::vector<std::pair<std::string, double>> worst_tests;  // test (file order) and RMS, µm
};

// Figures of a gap (measured − model, µm per row).
GapFigures DescribeGapFigures(const hexapod::EffectFitData& data, const PairedRows& pairs,
                              const Eigen::VectorXd& gap);

// σ of what repeated runs do not share: √(2·min(even, odd mean square)) over the pairs, 0 when
// the set has fewer than 3 pairs.
double PairRepeatability(const PairedRows& pairs, const Eigen::VectorXd& residual);

// "mostly even (…)", "follows |tilt| (r = …)" …: words chosen from the figures.
std::string ParityWords(double even_pct, double odd_pct);
std::string FollowsWords(const char* what, double r);

// The description of a gap that no registered effect explains.
std::string MisfitSentence(const GapFigures& g, double gap_rms_um, double repeat_um);

}  // namespace km::discovery
