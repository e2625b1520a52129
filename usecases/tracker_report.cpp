// JSON mapping of the laser-tracker self-calibration (docs/formats.md §3 `tracker selfcal`), shared
// by the CLI and the server.
#include "usecases/tracker_report.h"

#include <algorithm>
#include <cmath>

#include "analysis/core/errors.h"
#include "analysis/tracker/selfcal_uncertainty.h"
#include "ingest/tracker_parser.h"
#include "usecases/uncertainty_json.h"

namespace km::usecases {

namespace {

using nlohmann::json;

json Vec(const Eigen::Vector3d& v) {
  if (!v.allFinite()) return nullptr;
  return json::array({v.x(), v.y(), v.z()});
}

json Num(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

json DecompositionToJson(const tracker::GeometricDecomposition& d) {
  json out;
  out["centre_mm"] = Vec(d.centre_mm);
  out["half_range_mm"] = Vec(d.half_range_mm);
  out["scale_ppm"] = {{"x", d.scale_ppm.x()}, {"y", d.scale_ppm.y()}, {"z", d.scale_ppm.z()}};
  out["scale_sigma_ppm"] = {
      {"x", d.scale_sigma_ppm.x()}, {"y", d.scale_sigma_ppm.y()}, {"z", d.scale_sigma_ppm.z()}};
  out["squareness_um_per_m"] = {{"xy", d.squareness_um_per_m(0)},
                                {"yz", d.squareness_um_per_m(1)},
                                {"zx", d.squareness_um_per_m(2)}};
  out["squareness_sigma_um_per_m"] = {{"xy", d.squareness_sigma_um_per_m(0)},
                                      {"yz", d.squareness_sigma_um_per_m(1)},
                                      {"zx", d.squareness_sigma_um_per_m(2)}};
  json terms = json::array();
  for (const auto& t : d.terms) {
    terms.push_back({{"axis", std::string(1, t.axis)},
                     {"direction", std::string(1, t.direction)},
                     {"kind", t.axis == t.direction ? "positioning" : "straightness"},
                     {"order", t.order},
                     {"basis", "legendre"},
                     {"value_um", t.value_um},
                     {"sigma_um", t.sigma_um}});
  }
  out["terms"] = terms;
  out["residual_rms_um"] = d.residual_rms_um;
  out["sigma_um"] = d.sigma_um;
  out["uncertainty"] = d.propagated ? "propagated from the self-calibration covariance"
                                    : "from the model misfit (errors taken as independent)";
  out["fixed"] = d.fixed;
  return out;
}

// The tracker's one uncertainty input (docs/formats.md §1.2), as the file states it.
UncertaintyInput RangingInput(const std::map<std::string, std::string>& metadata) {
  const auto u = HeaderNumber(metadata, "u_ranging_um");
  return {"u_ranging_um", u.value_or(0.0), "µm", u.has_value()};
}

// Half-width of the normal 95 % interval in standard deviations.
constexpr double kNormal95 = 1.959964;

json LeastSquaresBudget(double sigma_um, double contribution_um) {
  return {{"input", "least squares (a-posteriori reading σ)"},
          {"u", sigma_um},
          {"unit", "µm"},
          {"contribution_um", contribution_um}};
}

// Per point [U_x, U_y, U_z] (k = 2) of the volumetric error from its standard uncertainties;
// null for a dropped point.
json PointsU(const std::vector<Eigen::Vector3d>& u_um) {
  json rows = json::array();
  for (const auto& u : u_um) rows.push_back(Vec(2.0 * u));
  return rows;
}

// The tracker coordinates the gauge leaves free (x of tracker 2, x and y of tracker 3, all of
// the others), keyed as the Monte Carlo figures are.
template <typename F>
void ForFreeTrackerAxes(const tracker::SelfCalResult& r, F&& f) {
  static const char* axis[3] = {"x", "y", "z"};
  for (std::size_t j = 0; j < r.trackers_mm.size(); ++j) {
    for (int a = 0; a < std::min<int>(static_cast<int>(j), 3); ++a) {
      f("trackers_mm[" + std::to_string(j) + "]." + axis[a], j, a);
    }
  }
}

// No ranging uncertainty stated: the least-squares σ alone (the a-posteriori σ of the readings,
// a Type A evaluation) gives the tracker positions and the volumetric errors a U.
json LeastSquaresUncertainty(const tracker::SelfCalResult& r, const UncertaintyInput& input) {
  json j = NoUncertaintyJson({input});
  j["method"] = "least squares";
  j["k"] = 2.0;
  j["coverage_probability"] = 0.95;
  json figures = json::object();
  ForFreeTrackerAxes(r, [&](const std::string& key, std::size_t t, int a) {
    if (t >= r.tracker_uncertainty_um.size()) return;
    const double u = r.tracker_uncertainty_um[t](a), x = 1e3 * r.trackers_mm[t](a);
    figures[key] = {{"u_um", u},     {"U_um", 2.0 * u},
                    {"k", 2.0},      {"interval_um", {x - kNormal95 * u, x + kNormal95 * u}},
                    {"u_lsq_um", u}, {"budget", json::array({LeastSquaresBudget(r.sigma_um, u)})}};
  });
  j["figures"] = figures;
  j["volumetric_error_U_um"] = PointsU(r.position_uncertainty_um);
  j["notes"] = json::array(
      {"u_ranging_um not stated: U from the least-squares σ alone (sigma_um, the scatter of the "
       "readings about the model), for the tracker positions and the volumetric errors"});
  return j;
}

// u_ranging_um stated: the Monte Carlo propagation through the solve, each figure that has a
// least-squares σ taking the larger of the two (both are the readings' scatter propagated).
json RangingUncertaintyJson(const tracker::TrackerReadings& readings,
                            const tracker::SelfCalResult& r,
                            const tracker::SelfCalSolution& solution,
                            const UncertaintyInput& input) {
  const tracker::RangingUncertainty p =
      tracker::PropagateRangingUncertainty(readings, r, solution, input.u);
  const std::size_t nf = p.figure_keys.size();
  uncertainty::McResult mc = p.mc;
  mc.outputs.resize(nf);
  std::vector<uncertainty::GumCheck> gum(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    gum[f].name = p.figure_keys[f];
    gum[f].u_gum = p.u_gum_um[f];
    gum[f].u_mc = mc.outputs[f].u;
    if (std::isfinite(p.u_gum_um[f]) && mc.outputs[f].u > 0) {
      gum[f].relative_difference = std::abs(p.u_gum_um[f] - mc.outputs[f].u) / mc.outputs[f].u;
      gum[f].differs = gum[f].relative_difference > 0.05;
    }
  }
  json j = UncertaintyJson(mc, {input}, p.figure_keys, gum);
  for (std::size_t f = 0; f < nf; ++f) {
    json& fig = j["figures"][p.figure_keys[f]];
    if (!std::isfinite(p.u_gum_um[f])) fig.erase("u_gum_um");
    const int t = p.figure_tracker[f];
    if (t < 0 || static_cast<std::size_t>(t) >= r.tracker_uncertainty_um.size()) continue;
    const double u_lsq = r.tracker_uncertainty_um[static_cast<std::size_t>(t)](p.figure_axis[f]);
    const double u_mc = mc.outputs[f].u;
    fig["u_mc_um"] = u_mc;
    fig["u_lsq_um"] = u_lsq;
    fig["budget"].push_back(LeastSquaresBudget(r.sigma_um, u_lsq));
    if (u_lsq > u_mc) {
      const double x = p.figure_value_um[f];
      fig["u_um"] = u_lsq;
      fig["U_um"] = 2.0 * u_lsq;
      fig["interval_um"] = {x - kNormal95 * u_lsq, x + kNormal95 * u_lsq};
    }
  }
  std::vector<Eigen::Vector3d> u_points(r.position_uncertainty_um.size(),
                                        Eigen::Vector3d::Constant(std::nan("")));
  for (std::size_t i = 0; i < p.point_output.size() && i < u_points.size(); ++i) {
    if (p.point_output[i] < 0) continue;
    for (int a = 0; a < 3; ++a) {
      const double u_mc = p.mc.outputs[static_cast<std::size_t>(p.point_output[i] + a)].u;
      u_points[i](a) = std::max(u_mc, r.position_uncertainty_um[i](a));
    }
  }
  j["volumetric_error_U_um"] = PointsU(u_points);
  j["notes"] = json::array(
      {"each draw adds N(0, u_ranging_um²) to every reading in use and re-solves from the "
       "result (the readings rejected stay out)",
       "where a figure has a least-squares σ (tracker_uncertainty_um, position_uncertainty_um) "
       "its u is the larger of that σ and the Monte Carlo u (u_mc_um, u_lsq_um): both propagate "
       "the scatter of the readings, so they are not added"});
  return j;
}

json TrackerUncertainty(const ingest::TrackerFile& f, const tracker::SelfCalResult& r,
                        const tracker::SelfCalSolution& solution) {
  const UncertaintyInput input = RangingInput(f.metadata);
  if (!(input.u > 0.0)) return LeastSquaresUncertainty(r, input);
  try {
    return RangingUncertaintyJson(f.readings, r, solution, input);
  } catch (const DidNotConverge& e) {
    json j = LeastSquaresUncertainty(r, input);
    j["method"] = std::string("least squares: the Monte Carlo propagation could not be made (") +
                  e.what() + ")";
    return j;
  }
}

}  // namespace

json TrackerResultToJson(const tracker::TrackerReadings& readings, const tracker::SelfCalResult& r,
                         const tracker::GeometricDecomposition* decomposition) {
  json out;
  out["machine_id"] = readings.machine_id;
  out["mode"] = tracker::ModeName(r.mode);
  json trackers = json::array(), tracker_sigma = json::array();
  for (const auto& t : r.trackers_mm) trackers.push_back(Vec(t));
  for (const auto& t : r.tracker_uncertainty_um) tracker_sigma.push_back(Vec(t));
  out["trackers_mm"] = trackers;
  out["tracker_uncertainty_um"] = tracker_sigma;
  json points = json::array(), errors = json::array(), sigma = json::array();
  for (std::size_t i = 0; i < r.points_mm.size(); ++i) {
    points.push_back(Vec(r.points_mm[i]));
    errors.push_back(Vec(r.volumetric_error_um[i]));
    sigma.push_back(Vec(r.position_uncertainty_um[i]));
  }
  out["point_ids"] = readings.point_ids;
  out["points_mm"] = points;
  out["volumetric_error_um"] = errors;
  out["position_uncertainty_um"] = sigma;
  out["residual_rms_um"] = Num(r.residual_rms_um);
  out["volumetric_error_max_um"] = Num(tracker::VolumetricErrorMaxUm(r));
  out["condition_number"] = Num(r.condition_number);
  out["sigma_um"] = Num(r.sigma_um);
  out["readings_used"] = r.readings_used;
  out["unknowns"] = r.unknowns;
  out["iterations"] = r.iterations;
  // One entry a interferometer segment: from row 0 (zeroed at point 1) or from a beam break.
  json dead = json::array();
  for (std::size_t s = 0; s < r.dead_path_mm.size(); ++s) {
    const int zero = r.dead_path_zero_row[s];
    dead.push_back(
        {{"tracker", r.dead_path_tracker[s] + 1},
         {"from_point", readings.point_ids[static_cast<std::size_t>(r.dead_path_from_row[s])]},
         {"zero", zero >= 0 ? "point" : "elsewhere"},
         {"zero_point",
          zero >= 0 ? json(readings.point_ids[static_cast<std::size_t>(zero)]) : json(nullptr)},
         {"dead_path_mm", Num(r.dead_path_mm[s])}});
  }
  out["dead_paths"] = dead;
  json rej = json::array();
  for (const auto& x : r.rejected) {
    rej.push_back({{"point", x.point_id},
                   {"tracker", x.tracker + 1},
                   {"residual_um", Num(x.residual_um)},
                   {"standardised_um", Num(x.standardised_um)},
                   {"reason", x.reason}});
  }
  out["rejected_readings"] = rej;
  // Warnings only: these points are kept with all their readings (tracker_selfcal.h).
  json spatial = json::array();
  for (const auto& x : r.spatial_outliers) {
    spatial.push_back({{"point", x.point_id},
                       {"index", x.row},
                       {"departure_um", Vec(x.departure_um)},
                       {"departure_sigmas", Num(x.departure_sigmas)},
                       {"largest_standardised_um", Num(x.largest_standardised_um)},
                       {"reason", x.reason}});
  }
  out["spatial_outliers"] = spatial;
  out["warnings"] = r.warnings;
  const auto& T = r.gauge_to_commanded;
  json R = json::array();
  for (int a = 0; a < 3; ++a) R.push_back({T.rotation(a, 0), T.rotation(a, 1), T.rotation(a, 2)});
  out["transform"] = {{"maps", "commanded_mm = rotation · points_mm + translation_mm"},
                      {"rotation", R},
                      {"translation_mm", Vec(T.translation_mm)},
                      {"mirrored", T.mirrored}};
  out["decomposition"] = decomposition ? DecompositionToJson(*decomposition) : json(nullptr);
  return out;
}

json AnalyzeTracker(const ingest::TrackerFile& f, const tracker::SelfCalOptions& options,
                    const tracker::DecompositionOptions& decomposition) {
  tracker::SelfCalSolution solution;
  const tracker::SelfCalResult r = tracker::SelfCalibrate(f.readings, options, &solution);
  json out;
  try {
    const auto d = tracker::DecomposeVolumetricError(f.readings.commanded_mm, r.volumetric_error_um,
                                                     decomposition, &r.error_covariance);
    out = TrackerResultToJson(f.readings, r, &d);
  } catch (const NotObservable& e) {
    out = TrackerResultToJson(f.readings, r, nullptr);
    out["decomposition_error"] = e.what();
  }
  out["uncertainty"] = TrackerUncertainty(f, r, solution);
  return out;
}

json AnalyzeTrackerFile(std::string_view bytes, const std::string& file,
                        const tracker::SelfCalOptions& options,
                        const tracker::DecompositionOptions& decomposition) {
  return AnalyzeTracker(ingest::ParseTrackerFile(bytes, file), options, decomposition);
}

}  // namespace km::usecases
