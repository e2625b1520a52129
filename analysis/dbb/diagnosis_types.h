// The DBB diagnosis' data types (diagnosis.h): a trace, the options, an entry and the result.
// Its internal parts include this header; users include diagnosis.h.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "analysis/dbb/dbb_types.h"
#include "analysis/serial_effects/registry.h"

namespace km::dbb {

struct DiagnosisTrace {
  Direction direction = Direction::kCcw;
  double radius_mm = 150.0;
  double feed_mm_min = 1000.0;
  std::vector<double> angle_rad;
  std::vector<double> dev_um;  // in-plane radial deviation about the nominal centre
  // Optional cos and sin of angle_rad (computed when absent).
  std::vector<double> cos_angle;
  std::vector<double> sin_angle;
};

struct DiagnosisOptions {
  double significance = 3.0;  // z for one-value effects (z + 1: two values, searched shape)
  double min_contribution_pct = 2.0;
  double confound_ratio = 0.1;       // part of a signature left after projecting out earlier ones
  double spike_min_width_deg = 0.1;  // raised to half the median sample step
  double spike_max_width_deg = 8.0;
  double cyclic_min_period_mm = 1.0;
  double cyclic_max_period_fraction = 1.0 / 3.0;  // of the radius
  double cyclic_detection_chi2 = 40.0;            // projection energy / σ² needed to try a period
  double stick_slip_min_period_deg = 0.2;         // raised to 3 median sample steps
  double stick_slip_max_period_deg = 2.0;
  double stick_slip_max_step_deg = 0.2;     // coarser sampling: stick_slip not assessed
  double stick_slip_detection_chi2 = 30.0;  // projection energy / σ² needed to try a sawtooth
  bool search_cyclic = true;
  // Threads for independent parts (the fixed-shape signatures, the two axes' spike and cyclic
  // searches): 0 = the machine's cores, 1 = in order. The result is the same.
  unsigned threads = 0;
  void Check() const;  // throws km::InvalidInput on nonsense
};

struct DiagnosisEntry {
  serial_effects::EffectId id = serial_effects::EffectId::kCentreOffset;
  std::string effect;  // contract name for the plane
  std::string unit;
  std::vector<double> value;              // one value, or [u, v] for centre_offset
  std::vector<double> uncertainty;        // standard uncertainty of each value
  std::vector<double> contribution_pct;   // per trace, input order
  std::vector<double> peak_to_valley_um;  // per trace: range of the effect's own signature
  double significance = 0.0;              // |value| / uncertainty (norm for two values)
  std::map<std::string, double> shape;    // shape parameters, e.g. period_mm, width_deg (and
                                          // for spikes width_s, the width in seconds)
  std::map<std::string, double> shape_uncertainty;  // of the fitted shape parameters
  std::string shape_kind;                           // reversal spikes: "exponential" or "gaussian"
  std::vector<double> params;                       // all model parameters
  bool named = false;
  double MaxContribution() const;
};

struct DiagnosisResult {
  std::vector<DiagnosisEntry> named;          // significant effects, ranked
  std::vector<DiagnosisEntry> candidates;     // every estimated effect (named or not)
  std::vector<std::string> not_identifiable;  // "effect (confounded with other)"
  double residual_rms_um = 0.0;               // after the final model
  double noise_um = 0.0;                      // σ from successive differences of the residual
  // Per trace: fitted form signature sum at the samples the diagnosis used (those on an axis
  // reversal are left out).
  std::vector<std::vector<double>> form_model_um;
};

// Axis letters of a plane (first, second), e.g. XY → ('x', 'y').
std::pair<char, char> AxisLetters(Plane plane);

}  // namespace km::dbb
