#include "server/servo/servo_service.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "ingest/machine_json.h"
#include "ingest/servo_parser.h"
#include "server/base/request_json.h"
#include "server/base/sha256.h"
#include "server/streams/streams.h"
#include "usecases/servo_report.h"

namespace km::server {
namespace {

namespace req = request;

struct Inputs {
  ingest::MachineDefinition machine;
  std::int64_t version = 0;
  std::vector<servo::ServoFile> files;
};

std::string MeasurementName(MeasurementId id, const std::string& filename) {
  return "measurement " + to_string(id) + " (" + filename + ")";
}

ingest::MachineDefinition Machine(ModelService& models, const std::string& machine_id,
                                  std::optional<std::int64_t> version, std::int64_t& used) {
  const MachineModelRecord rec = models.GetMachineModel(machine_id, version);
  used = rec.version;
  return ingest::ParseHexapodMachineJson(
      rec.document, "machine " + rec.machine_id + " version " + std::to_string(rec.version));
}

// The servo measurements of the request, read back and parsed, each of the machine.
std::vector<servo::ServoFile> Files(MeasurementStore& store, const nlohmann::json& request,
                                    const std::string& machine_id) {
  if (!request.contains("measurement_ids") || !request["measurement_ids"].is_array() ||
      request["measurement_ids"].empty()) {
    throw InvalidInput(req::kFile, 0, "measurement_ids",
                       "a non-empty list of servo measurement ids");
  }
  const auto& list = request["measurement_ids"];
  if (list.size() > kMaxServoMeasurements) {
    throw InvalidInput(req::kFile, 0, "measurement_ids",
                       "at most " + std::to_string(kMaxServoMeasurements) + " measurements");
  }
  std::vector<servo::ServoFile> files;
  std::set<std::int64_t> seen;
  std::size_t samples = 0;
  for (const auto& v : list) {
    if (!v.is_number_integer() || v.get<std::int64_t>() < 1 ||
        !seen.insert(v.get<std::int64_t>()).second) {
      throw InvalidInput(req::kFile, 0, "measurement_ids",
                         "ids are whole numbers from 1, each listed once");
    }
    const MeasurementId id(v.get<std::int64_t>());
    const auto rec = store.GetMeasurement(id);
    if (!rec) throw NotFound("measurement " + to_string(id) + " does not exist");
    if (rec->kind != "servo" || rec->machine_id != machine_id) {
      throw InvalidInput(
          req::kFile, 0, "measurement_ids",
          "measurement " + to_string(id) + " is not a servo record of " + machine_id);
    }
    files.push_back(ingest::ParseServoFile(store.GetRaw(id), MeasurementName(id, rec->filename)));
    samples += files.back().t_s.size();
    if (samples > kMaxServoSamples) {
      throw InvalidInput(req::kFile, 0, "measurement_ids",
                         "more than " + std::to_string(kMaxServoSamples) + " samples in all");
    }
  }
  return files;
}

Inputs Read(MeasurementStore& store, ModelService& models, const nlohmann::json& request) {
  if (!request.is_object()) throw InvalidInput(req::kFile, 0, "", "a JSON object is required");
  Inputs in;
  const std::string machine_id = req::RequiredString(request, "machine_id");
  std::optional<std::int64_t> version;
  if (request.contains("machine_version")) {
    version =
        req::WholeNumber(request, "machine_version", 1, std::numeric_limits<std::int64_t>::max());
  }
  in.machine = Machine(models, machine_id, version, in.version);
  in.files = Files(store, request, machine_id);
  for (const auto& f : in.files) {
    if (!f.hexapod) {
      throw InvalidInput(req::kFile, 0, "measurement_ids",
                         f.file + " is a feed-drive record, not hexapod strut loads");
    }
  }
  return in;
}

// The estimate kept as a result of each measurement it used (see kJointsAnalysis).
void StoreJoints(MeasurementStore& store, const nlohmann::json& j) {
  const std::string text = j.dump();
  const NewResult result{
      kJointsAnalysis,
      std::string(usecases::kServoAnalysisVersion) + " #" + Sha256Hex(text).substr(0, 16), text};
  for (const auto& id : j["measurement_ids"]) store.PutResult(id.get<MeasurementId>(), result);
}

// One stored estimate as an item of the history.
nlohmann::json HistoryItem(const ResultRecord& rec) {
  const auto j = ingest::ParseJsonText(rec.result_json, "stored document");
  nlohmann::json legs = nlohmann::json::array();
  nlohmann::json reference = nlohmann::json::array();
  for (const auto& leg : j["legs"]) {
    legs.push_back({{"leg", leg["leg"]},
                    {"resistance_Nm", leg["resistance_Nm"]},
                    {"sigma_Nm", leg["sigma_Nm"]},
                    {"reference_Nm", leg["reference_Nm"]},
                    {"ratio", leg["ratio"]},
                    {"level", leg["level"]},
                    {"evidence", leg["evidence"]}});
    reference.push_back(leg["reference_Nm"]);
  }
  nlohmann::json limits = j["limits"];
  limits["reference_Nm"] = reference;
  limits["reference_source"] = j["reference_source"];
  return {{"result_id", rec.analysis_version},
          {"measurement_ids", j["measurement_ids"]},
          {"estimated_at", rec.created_at},
          {"machine_version", j["machine_version"]},
          {"legs", legs},
          {"level", j["level"]},
          {"limits", limits}};
}

}  // namespace

nlohmann::json ServoService::Identify(const nlohmann::json& request) {
  Inputs in = Read(store_, models_, request);
  const bool save =
      request.contains("save") && request["save"].is_boolean() && request["save"].get<bool>();
  if (request.contains("save") && !request["save"].is_boolean()) {
    throw InvalidInput(req::kFile, 0, "save", "must be true or false");
  }
  const std::string note = req::OptionalString(request, "note", "");
  const auto r = servo::IdentifyLoads(
      in.machine.geometry, in.machine.physics.value_or(hexapod::MachinePhysics{}), in.files);
  nlohmann::json j = usecases::ServoIdentifyJson(in.machine.machine_id, in.files, r);
  j["machine_version"] = in.version;
  if (save) {
    const auto stored = models_.StoreMachineModel(usecases::MachineWithIdentified(in.machine, r),
                                                  "servo identification", note);
    j["saved"] = {{"machine_id", stored.machine_id},
                  {"version", stored.version},
                  {"created", stored.created}};
  }
  return j;
}

nlohmann::json ServoService::Joints(const nlohmann::json& request) {
  Inputs in = Read(store_, models_, request);
  servo::JointOptions o;
  o.level2_ratio = req::Number(request, "level2_ratio", o.level2_ratio);
  o.level3_ratio = req::Number(request, "level3_ratio", o.level3_ratio);
  o.increase_warn = req::Number(request, "increase_warn", o.increase_warn);
  o.increase_stop = req::Number(request, "increase_stop", o.increase_stop);
  if (request.contains("previous")) {
    o.previous_Nm = usecases::PreviousResistances(request["previous"].dump(), "request previous");
  }
  InFile(req::kFile, [&] { o.Check(); });
  const auto r = servo::EstimateJointResistance(
      in.machine.geometry, in.machine.physics.value_or(hexapod::MachinePhysics{}), in.files, o);
  nlohmann::json j = usecases::ServoJointsJson(in.machine.machine_id, r, o);
  j["machine_version"] = in.version;
  j["measurement_ids"] = request["measurement_ids"];
  StoreJoints(store_, j);
  return j;
}

nlohmann::json ServoService::JointHealth(const std::string& machine_id) {
  const auto machines = store_.ListMachines();
  if (std::none_of(machines.begin(), machines.end(),
                   [&](const MachineSummary& m) { return m.machine_id == machine_id; })) {
    throw NotFound("machine " + machine_id + " has no measurements and no model");
  }
  // Every stored estimate once (it is kept with each measurement it used), in the order first
  // met (measurements oldest first, their results as stored), then by the time stored.
  std::map<std::string, std::size_t> seen;
  std::vector<ResultRecord> found;
  MeasurementFilter f;
  f.machine_id = machine_id;
  f.kind = "servo";
  f.limit = 500;
  for (f.offset = 0;; f.offset += f.limit) {
    const auto page = store_.ListMeasurements(f);
    for (const auto& m : page.items) {
      for (auto& r : store_.GetResults(m.id)) {
        if (r.analysis != kJointsAnalysis ||
            !seen.emplace(r.analysis_version, found.size()).second) {
          continue;
        }
        found.push_back(std::move(r));
      }
    }
    if (page.items.empty() || f.offset + f.limit >= page.total) break;
  }
  std::stable_sort(found.begin(), found.end(), [](const ResultRecord& a, const ResultRecord& b) {
    return a.created_at < b.created_at;
  });
  nlohmann::json estimates = nlohmann::json::array();
  for (const auto& r : found) estimates.push_back(HistoryItem(r));
  const nlohmann::json limits =
      estimates.empty() ? nlohmann::json(nullptr) : estimates.back()["limits"];
  return {{"machine_id", machine_id}, {"limits", limits}, {"estimates", estimates}};
}

nlohmann::json ServoService::Force(MeasurementId measurement_id,
                                   std::optional<std::int64_t> machine_version) {
  const auto rec = store_.GetMeasurement(measurement_id);
  if (!rec) throw NotFound("measurement " + to_string(measurement_id) + " does not exist");
  if (rec->kind != "servo") {
    throw InvalidInput("", 0, "id",
                       "measurement " + to_string(measurement_id) + " is not a servo record");
  }
  std::int64_t version = 0;
  const auto machine = Machine(models_, rec->machine_id, machine_version, version);
  if (!machine.physics) {
    throw InvalidInput("", 0, "machine_id",
                       "the model of " + rec->machine_id +
                           " has no gravity and friction blocks (identify and save first)");
  }
  const auto file = ingest::ParseServoFile(store_.GetRaw(measurement_id),
                                           MeasurementName(measurement_id, rec->filename));
  if (!file.hexapod) {
    throw InvalidInput("", 0, "id", "a feed-drive record has no tool-tip force");
  }
  const auto f = servo::EstimateExternalForce(machine.geometry, *machine.physics, file,
                                              usecases::ForceOptionsOf(machine));
  nlohmann::json j = usecases::ServoForceJson(machine.machine_id, file, f);
  j["machine_version"] = version;
  return j;
}

namespace {

// The value of a channel at time t by linear interpolation; nullopt outside its samples.
std::optional<double> At(const ChannelSamples& c, std::int64_t t) {
  if (c.t_us.empty() || t < c.t_us.front() || t > c.t_us.back()) return std::nullopt;
  const auto it = std::lower_bound(c.t_us.begin(), c.t_us.end(), t);
  const auto k = static_cast<std::size_t>(it - c.t_us.begin());
  if (c.t_us[k] == t || k == 0) return c.value_um[k];
  const double w =
      static_cast<double>(t - c.t_us[k - 1]) / static_cast<double>(c.t_us[k] - c.t_us[k - 1]);
  return (1.0 - w) * c.value_um[k - 1] + w * c.value_um[k];
}

std::int64_t Channel(const nlohmann::json& j, const std::string& key, const std::string& field) {
  if (!j.contains(key) || !j[key].is_number_integer() || j[key].get<std::int64_t>() < 0 ||
      j[key].get<std::int64_t>() > 65535) {
    throw InvalidInput(req::kFile, 0, field + "." + key, "a channel number 0 … 65535 is required");
  }
  return j[key].get<std::int64_t>();
}

}  // namespace

namespace {

// One column of a record made from a stream: a channel's samples times a scale.
struct Column {
  std::string name;
  ChannelSamples samples;
  double scale = 1.0;
};

struct StreamRange {
  StreamStore* store = nullptr;
  StreamId stream;
  std::int64_t from_us = 0, to_us = 0;
  Column Read(const std::string& name, std::int64_t channel, double scale) const {
    return {name, ReadChannelSamples(*store, stream, channel, from_us, to_us), scale};
  }
};

// The column-header row and the rows: one at each sample of the first column, the other
// columns interpolated in time to it; rows outside any column's span are left out.
std::string Rows(const std::vector<Column>& cols) {
  std::string text = "t_s";
  for (const auto& c : cols) text += "," + c.name;
  text += "\n";
  const auto& rows = cols.front().samples;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::int64_t t = rows.t_us[i];
    std::string line = nlohmann::json(static_cast<double>(t - rows.t_us.front()) * 1e-6).dump();
    bool complete = true;
    for (std::size_t c = 0; c < cols.size() && complete; ++c) {
      const auto v = At(cols[c].samples, t);
      complete = v.has_value();
      if (complete) line += "," + nlohmann::json(*v * cols[c].scale).dump();
    }
    if (complete) text += line + "\n";
  }
  return text;
}

std::string ForceHeader(const nlohmann::json& request) {
  std::string text = "# force_unit: " + req::OptionalString(request, "force_unit", "N") + "\n";
  if (!request.contains("force_constant_N_per_A")) return text;
  const auto& k = request["force_constant_N_per_A"];
  if (!k.is_array()) throw InvalidInput(req::kFile, 0, "force_constant_N_per_A", "an array");
  std::string list;
  for (const auto& v : k) {
    if (!v.is_number()) throw InvalidInput(req::kFile, 0, "force_constant_N_per_A", "numbers");
    list += (list.empty() ? "" : ", ") + nlohmann::json(v.get<double>()).dump();
  }
  return text + "# force_constant_N_per_A: " + list + "\n";
}

// Feed-drive axes: {"axes": [{"axis", "position_channel" (µm), "force_channel"}, …]}.
std::string FeedDriveRecord(const StreamRange& range, const nlohmann::json& request) {
  const auto& axes = request["axes"];
  if (!axes.is_array() || axes.empty() || axes.size() > 6) {
    throw InvalidInput(req::kFile, 0, "axes",
                       "1 … 6 objects {\"axis\", \"position_channel\", \"force_channel\"}");
  }
  std::vector<Column> cols;
  std::string first;
  for (std::size_t a = 0; a < axes.size(); ++a) {
    const auto& ax = axes[a];
    const std::string field = "axes[" + std::to_string(a) + "]";
    if (!ax.is_object()) throw InvalidInput(req::kFile, 0, field, "must be an object");
    std::string name = req::RequiredString(ax, "axis");
    for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (a == 0) first = name;
    const std::string pos = a == 0 ? "pos_mm" : "pos_" + name + "_mm";
    const std::string force = a == 0 ? "force" : "force_" + name;
    cols.push_back(range.Read(pos, Channel(ax, "position_channel", field), 1e-3));
    cols.push_back(range.Read(force, Channel(ax, "force_channel", field), 1.0));
  }
  return "# motion: path\n# axis: " + first + "\n" + ForceHeader(request) + Rows(cols);
}

// Hexapod struts: {"struts": {"pose_channels": [x, y, z, a, b, c], "force_channels": [f1 … f6],
// "pose_scale"?: [6] (default 0.001: µm → mm, millidegrees → degrees), "tool_length_mm",
// "motion"?, "direction"?}}.
std::string HexapodRecord(const StreamRange& range, const nlohmann::json& request) {
  const auto& st = request["struts"];
  if (!st.is_object()) throw InvalidInput(req::kFile, 0, "struts", "must be an object");
  const auto six = [&](const char* key) {
    if (!st.contains(key) || !st[key].is_array() || st[key].size() != 6) {
      throw InvalidInput(req::kFile, 0, std::string("struts.") + key, "six channels");
    }
    return st[key];
  };
  const auto pose = six("pose_channels");
  const auto force = six("force_channels");
  std::vector<double> scale(6, 1e-3);
  if (st.contains("pose_scale")) {
    const auto ps = six("pose_scale");
    for (std::size_t k = 0; k < 6; ++k) {
      if (!ps[k].is_number() || !std::isfinite(ps[k].get<double>()) || ps[k].get<double>() == 0.0) {
        throw InvalidInput(req::kFile, 0, "struts.pose_scale", "six finite, non-zero numbers");
      }
      scale[k] = ps[k].get<double>();
    }
  }
  static const char* kPose[] = {"x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg"};
  std::vector<Column> cols;
  for (std::size_t k = 0; k < 6; ++k) {
    const nlohmann::json one = {{"channel", pose[k]}};
    cols.push_back(range.Read(kPose[k], Channel(one, "channel", "struts.pose_channels"), scale[k]));
  }
  for (std::size_t k = 0; k < 6; ++k) {
    const nlohmann::json one = {{"channel", force[k]}};
    cols.push_back(range.Read("f" + std::to_string(k + 1),
                              Channel(one, "channel", "struts.force_channels"), 1.0));
  }
  std::string head = "# motion: " + req::OptionalString(st, "motion", "path") + "\n";
  if (st.contains("direction"))
    head += "# direction: " + req::RequiredString(st, "direction") + "\n";
  head += "# tool_length_mm: " +
          nlohmann::json(req::Number(st, "tool_length_mm", std::nullopt)).dump() + "\n";
  return head + ForceHeader(request) + Rows(cols);
}

}  // namespace

UploadOutcome ServoService::FromStream(StreamId stream_id, const nlohmann::json& request) {
  const auto rec = streams_.store().GetStream(stream_id);
  if (!rec) throw NotFound("stream " + to_string(stream_id) + " does not exist");
  if (!request.is_object()) throw InvalidInput(req::kFile, 0, "", "a JSON object is required");
  if (request.contains("axes") == request.contains("struts")) {
    throw InvalidInput(req::kFile, 0, "axes",
                       "give either \"axes\" (feed drives) or \"struts\" (a hexapod)");
  }
  constexpr auto kMin = std::numeric_limits<std::int64_t>::min();
  constexpr auto kMax = std::numeric_limits<std::int64_t>::max();
  StreamRange range;
  range.store = &streams_.store();
  range.stream = stream_id;
  range.from_us = req::WholeNumber(request, "from_us", kMin, kMax, kMin);
  range.to_us = req::WholeNumber(request, "to_us", kMin, kMax, kMax);
  streams_.hub().Flush(stream_id);  // every sample received so far
  const std::string body =
      request.contains("axes") ? FeedDriveRecord(range, request) : HexapodRecord(range, request);
  const std::string text =
      "# format: kinemetric-servo/1\n# machine_id: " + rec->machine_id +
      "\n# test_id: " + req::OptionalString(request, "test_id", "stream-" + to_string(stream_id)) +
      "\n# source_stream: " + to_string(stream_id) + "\n" + body;
  return measurements_.Upload(text, "stream-" + to_string(stream_id) + "-servo.csv");
}

}  // namespace km::server
