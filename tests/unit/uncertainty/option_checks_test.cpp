// Every options struct of an analysis refuses nonsense before any work, naming the option: the
// DBB analysis and its uncertainty, the Monte Carlo ([JCGM 101] §7.2: M ≥ 1/(1 − p)), the
// tracker's ranging propagation, the hexapod's effect fit and forward kinematics. The defaults
// pass.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "analysis/core/errors.h"
#include "analysis/dbb/dbb_uncertainty.h"
#include "analysis/dbb/full_analysis.h"
#include "analysis/hexapod/effect_fit.h"
#include "analysis/hexapod/kinematics.h"
#include "analysis/tracker/selfcal_uncertainty.h"
#include "analysis/uncertainty/monte_carlo.h"
#include "tests/unit/expect_error.h"

namespace km {
namespace {

template <typename O, typename Set>
std::string RefusedField(O o, Set set) {
  set(o);
  return test::Expect<InvalidInput>([&] { o.Check(); }).field();
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(OptionChecks, MonteCarlo) {
  using O = uncertainty::McOptions;
  EXPECT_NO_THROW(O{}.Check());
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.p = 1.0; }), "p");
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.p = kNaN; }), "p");
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.k = 0.0; }), "k");
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.k = kNaN; }), "k");
  // p = 0.95 needs 20 draws; 19 are too few, 20 enough.
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.draws = 19; }), "draws");
  O twenty;
  twenty.draws = 20;
  EXPECT_NO_THROW(twenty.Check());
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.adaptive = true, o.batch = 10; }), "batch");
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.adaptive = true, o.max_draws = 15'000; }), "adaptive");
}

TEST(OptionChecks, TrackerRanging) {
  using O = tracker::RangingUncertaintyOptions;
  EXPECT_NO_THROW(O{}.Check());
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.draws = 19; }), "draws");
}

TEST(OptionChecks, HexapodEffectFit) {
  using O = hexapod::EffectFitOptions;
  EXPECT_NO_THROW(O{}.Check());
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.max_iterations = 0; }), "max_iterations");
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.relative_tolerance = 0.0; }), "relative_tolerance");
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.stall_tolerance = kNaN; }), "stall_tolerance");
}

TEST(OptionChecks, HexapodForwardKinematics) {
  using O = hexapod::ForwardOptions;
  EXPECT_NO_THROW(O{}.Check());
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.max_iterations = -1; }), "max_iterations");
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.strut_tolerance_mm = 0.0; }), "strut_tolerance_mm");
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.step_tolerance_mm = kNaN; }), "step_tolerance_mm");
  EXPECT_EQ(RefusedField(O{}, [](O& o) { o.max_condition_number = 1.0; }), "max_condition_number");
}

TEST(OptionChecks, DbbAnalysisAndUncertainty) {
  using A = dbb::DbbAnalysisOptions;
  EXPECT_NO_THROW(A{}.Check());
  EXPECT_EQ(RefusedField(A{}, [](A& o) { o.harmonic_orders = 0; }), "harmonic_orders");
  using U = dbb::DbbUncertaintyOptions;
  EXPECT_NO_THROW(U{}.Check());
  EXPECT_EQ(RefusedField(U{}, [](U& o) { o.draws = 19; }), "draws");
}

}  // namespace
}  // namespace km
