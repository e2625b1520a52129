// JSON of the servo-load analyses (docs/formats.md §3.10–3.13), shared by the CLI and the
// service so a stored result equals the CLI's output: `servo identify`, `servo force`,
// `servo joints`, `servo feed-drive`, and the summary stored with an uploaded
// `kinemetric-servo/1` file.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/dbb/dbb_types.h"
#include "analysis/servo/external_force.h"
#include "analysis/servo/feed_drive.h"
#include "analysis/servo/identify.h"
#include "analysis/servo/joint_resistance.h"
#include "analysis/servo/servo_types.h"
#include "ingest/machine_json.h"

namespace km::usecases {

inline constexpr const char* kServoAnalysisVersion = "servo/1";

// {machine_id, files[], samples, identified{…}, uncertainty{…}, residual_rms_N[6],
//  residual_sigma_N, rows_used[6], condition_number, fixed[], fixed_reasons[],
//  held_design_values[], iterations, joint_friction{torque_Nm, torque_per_N_m, ramp_mm,
//  ramp_sigma_mm, residual_rms_N, step_residual_rms_N}}
nlohmann::json ServoIdentifyJson(const std::string& machine_id,
                                 const std::vector<servo::ServoFile>& files,
                                 const servo::IdentifyResult& r);

// The machine document with the identified values written into its `gravity` and `friction`
// blocks and the `joint_friction` effect with the identified torque, load factor and ramp
// in its `effects` block (known parameters; other keys kept), pretty-printed.
std::string MachineWithIdentified(const ingest::MachineDefinition& machine,
                                  const servo::IdentifyResult& r);

// {machine_id, file, test_id, t_s[], force_N[][3], sigma_N[][3], mean_force_N[3],
//  mean_sigma_N[3], strut_noise_N[6], joint_ramp_mm, screw_ramp_mm, ramps_from{joint, screw}}
nlohmann::json ServoForceJson(const std::string& machine_id, const servo::ServoFile& file,
                              const servo::ForceEstimate& f);

// The force options of a machine: the ramp of its `joint_friction` effect, when it has one.
servo::ForceOptions ForceOptionsOf(const ingest::MachineDefinition& machine);

// {machine_id, legs[] {leg, resistance_Nm, sigma_Nm, level, evidence, reference_Nm, ratio,
//  previous_Nm, joints[] {joint, resistance_Nm, sigma_Nm, identified}, screw_friction_N,
//  screw_friction_sigma_N}, level, reference_source, limits{}, pairs[], rows, residual_rms_N,
//  condition_number, not_identifiable[]}
nlohmann::json ServoJointsJson(const std::string& machine_id, const servo::JointsResult& r,
                               const servo::JointOptions& o);

// The per-leg resistances of an earlier `servo joints` result (legs[].resistance_Nm by leg).
// Throws InvalidInput naming `file` and the field.
std::array<double, 6> PreviousResistances(const std::string& text, const std::string& file);

// {machine_id, axes[] {axis, coulomb_N, …}, coulomb_N, viscous_N_s_per_mm, ripple[],
//  lugre{}, lugre_sigma{}, lugre_identifiable{} (a parameter not identifiable is null in lugre
//  and lugre_sigma), lugre_note, stick_motion_um} — the first axis's values also at the top
//  level (docs/formats.md §3.13).
nlohmann::json ServoFeedDriveJson(const std::string& machine_id,
                                  const std::vector<servo::FeedDriveResult>& axes);

// DBB tests of the same machine next to the feed drive's stick-motion prediction ([Fujita
// thesis] ch. 2–3): per test {file, test_id, direction, radius_mm, feed_mm_min, measured[]
// (the diagnosis' reversal_spike_* and stick_slip entries: effect, value, uncertainty, unit),
// predicted_stick_motion_um (the test's radius and feed, gain `kp_per_s`; null without a
// gain or a LuGre fit)}.
nlohmann::json DbbStickComparisonJson(const std::vector<dbb::DbbTest>& tests,
                                      const std::vector<std::string>& names,
                                      const servo::FeedDriveResult& drive,
                                      std::optional<double> kp_per_s);

// The summary stored with an upload: {record ("hexapod" | "feed_drive"), samples, duration_s,
//  and per strut force_min_N[6], force_max_N[6], force_rms_N[6] or per axis axes[] {axis,
//  stroke_mm, force_min_N, force_max_N, force_rms_N}}.
nlohmann::json ServoSummaryJson(const servo::ServoFile& f);

}  // namespace km::usecases
