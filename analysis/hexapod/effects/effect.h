// Vocabulary of the hexapod error effects (docs/hexapod-effects.md). An effect changes what the
// real machine does for a commanded pose and motion history: it adds strut-length errors Δs_j
// (mm, to the realised joint-to-joint lengths) and/or changes the real tool length by Δl (mm).
// The simulator, the calibration with effects and the discovery all evaluate effects through
// this one interface. Adding an effect = one file in this folder + one line in effect_list.h.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "analysis/dbb/dbb_types.h"
#include "analysis/hexapod/kinematics.h"
#include "analysis/hexapod/statics.h"

namespace km::hexapod {

// One test prepared for effect evaluation: the commanded path and what depends only on it.
struct TestPath {
  std::string test_id;
  dbb::Direction direction = dbb::Direction::kCcw;
  double tool_length_mm = 0.0;
  double feed_mm_min = 0.0;
  double radius_mm = 0.0;
  std::vector<Pose> pose;          // commanded tool-tip pose per sample
  std::vector<Vector6d> strut_mm;  // commanded actuator values (model geometry)
  std::vector<double> time_s;      // since the set's reference time (0-based if untimed)
  bool timed = false;              // the test carries a timestamp
  std::optional<double> temperature_c;
  std::vector<StrutFrame> frame;    // strut geometry at the commanded pose (model geometry)
  std::vector<Vector6d> gravity_N;  // gravity axial forces (empty when the machine has none)
  // Change of the gravity axial forces per kg of platform mass at the machine file's centre of
  // gravity, and per kg·mm of m_P·Δc along each platform axis (the platform variant of
  // gravity_deflection; the statics are linear in these loads, eqs. 3.5–3.7).
  std::vector<Vector6d> gravity_per_kg;
  std::vector<std::array<Vector6d, 3>> gravity_per_kg_mm;
  // The commanded motion is one closed turn (its last pose next to its first); otherwise an
  // open path (partial arc, lead-in or lead-out).
  bool closed_turn = true;
};

// What the effects of a test set may depend on.
struct EffectSetup {
  const MachinePhysics* physics = nullptr;
  std::vector<double> tool_lengths_mm;  // distinct, ascending
  bool all_timed = false;
  bool all_temperatures = false;
  double reference_temperature_c = 0.0;  // of the earliest test
};

struct EffectParameter {
  std::string name;
  std::string unit;
  double value = 0.0;  // default / starting value
  double lower = 0.0;
  double upper = 0.0;
  bool free = true;
  double scale = 1.0;  // typical size (finite-difference steps, damping)
};

// Model terms shared between effects (the strut compliance of gravity_deflection is also the
// one that deflects the struts under joint friction).
struct ModelTerms {
  const MachinePhysics* physics = nullptr;
  double k_stiff2_mm_per_N = 0.0;
  double platform_mass_change_kg = 0.0;                   // m_P − m_P(file)
  Eigen::Vector3d platform_moment_change_kg_mm{0, 0, 0};  // m_P·(c − c(file)), platform frame
  // The strut axial gravity forces ĝ at sample i with the model's platform.
  Vector6d GravityAt(const TestPath& path, std::size_t i) const {
    Vector6d g = path.gravity_N[i];
    if (platform_mass_change_kg != 0.0) g += platform_mass_change_kg * path.gravity_per_kg[i];
    for (int k = 0; k < 3; ++k)
      if (platform_moment_change_kg_mm[k] != 0.0)
        g += platform_moment_change_kg_mm[k] * path.gravity_per_kg_mm[i][k];
    return g;
  }
};

// Per-sample output of the effects of one test, summed over the effects.
struct Perturbation {
  std::vector<Vector6d> ds_mm;
  std::vector<double> dl_mm;
  void Reset(std::size_t n) {
    ds_mm.assign(n, Vector6d::Zero());
    dl_mm.assign(n, 0.0);
  }
};

class HexapodEffect {
 public:
  virtual ~HexapodEffect() = default;
  virtual const char* Name() const = 0;  // docs/formats.md §4 name
  // Parameters for this test set with their defaults; empty when the effect cannot apply
  // (e.g. drift without timestamps, gravity without the machine's masses).
  virtual std::vector<EffectParameter> Parameters(const EffectSetup& setup) const = 0;
  // Adds this effect's Δs and Δl to every sample of `path`.
  virtual void Apply(const TestPath& path, const double* params, const ModelTerms& terms,
                     const EffectSetup& setup, Perturbation& out) const = 0;
  // How the effect shows in DBB traces, in words (for the evidence of a discovery).
  virtual const char* Signature() const = 0;
  // The forms a discovery tries (e.g. ramp lengths, the platform's mass fitted or not, growth
  // uniform or with strut length). Each has its parameters with start values and free flags
  // (those of the refit once accepted); `held` lists free parameters held at their value while
  // the candidate is screened linearly (shape parameters such as a ramp length).
  struct Variant {
    std::string label;  // "" for the plain form
    std::vector<EffectParameter> params;
    std::vector<int> held;
  };
  virtual std::vector<Variant> Variants(const EffectSetup& setup) const {
    auto p = Parameters(setup);
    if (p.empty()) return {};
    return {{"", std::move(p), {}}};
  }
};

}  // namespace km::hexapod
