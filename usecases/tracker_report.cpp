// JSON mapping of the laser-tracker self-calibration (docs/formats.md §3 `tracker selfcal`), shared
// by the CLI and the server.
#include "usecases/tracker_report.h"

#include <algorithm>
#include <cmath>

#include "analysis/core/errors.h"
#include "ingest/tracker_parser.h"

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
  const tracker::SelfCalResult r = tracker::SelfCalibrate(f.readings, options);
  try {
    const auto d = tracker::DecomposeVolumetricError(f.readings.commanded_mm, r.volumetric_error_um,
                                                     decomposition, &r.error_covariance);
    return TrackerResultToJson(f.readings, r, &d);
  } catch (const NotObservable& e) {
    json out = TrackerResultToJson(f.readings, r, nullptr);
    out["decomposition_error"] = e.what();
    return out;
  }
}

json AnalyzeTrackerFile(std::string_view bytes, const std::string& file,
                        const tracker::SelfCalOptions& options,
                        const tracker::DecompositionOptions& decomposition) {
  return AnalyzeTracker(ingest::ParseTrackerFile(bytes, file), options, decomposition);
}

}  // namespace km::usecases
