#include "ingest/machine_json.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "ingest/identifiers.h"
#include "ingest/json_text.h"

namespace km::ingest {

namespace {

using nlohmann::json;

double Number(const json& v, const std::string& file, const std::string& field) {
  if (!v.is_number()) throw InvalidInput(file, 0, field, "must be a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw InvalidInput(file, 0, field, "must be finite");
  return d;
}

std::array<Eigen::Vector3d, 6> Points6x3(const json& doc, const std::string& key,
                                         const std::string& file) {
  if (!doc.contains(key)) throw InvalidInput(file, 0, key, "missing (hexapod machines need it)");
  const json& a = doc[key];
  if (!a.is_array() || a.size() != 6)
    throw InvalidInput(file, 0, key, "must be an array of 6 points");
  std::array<Eigen::Vector3d, 6> out;
  for (std::size_t j = 0; j < 6; ++j) {
    const std::string fj = key + "[" + std::to_string(j) + "]";
    if (!a[j].is_array() || a[j].size() != 3) {
      throw InvalidInput(file, 0, fj, "must be an array of 3 numbers (x, y, z)");
    }
    for (std::size_t c = 0; c < 3; ++c) {
      out[j][static_cast<Eigen::Index>(c)] =
          Number(a[j][c], file, fj + "[" + std::to_string(c) + "]");
    }
  }
  return out;
}

}  // namespace

MachineDefinition ParseMachineJson(std::string_view bytes, const std::string& file) {
  json doc = ParseJsonText(bytes, file);
  if (!doc.is_object()) throw InvalidInput(file, 0, "", "the machine file must be a JSON object");
  if (!doc.contains("format") || !doc["format"].is_string()) {
    throw InvalidInput(file, 0, "format", "missing (expected \"kinemetric-machine/1\")");
  }
  if (doc["format"].get<std::string>() != kMachineFormat) {
    throw InvalidInput(file, 0, "format",
                       "unsupported format '" + doc["format"].get<std::string>() +
                           "' (expected \"kinemetric-machine/1\")");
  }
  MachineDefinition m;
  m.source_json = std::string(bytes);
  if (!doc.contains("machine_id") || !doc["machine_id"].is_string() ||
      doc["machine_id"].get<std::string>().empty()) {
    throw InvalidInput(file, 0, "machine_id", "missing or not a non-empty string");
  }
  m.machine_id = doc["machine_id"].get<std::string>();
  CheckMachineId(m.machine_id, file, 0);
  if (!doc.contains("kind") || !doc["kind"].is_string()) {
    throw InvalidInput(file, 0, "kind", "missing (expected \"hexapod\" or \"serial\")");
  }
  m.kind = doc["kind"].get<std::string>();
  if (m.kind != "hexapod" && m.kind != "serial") {
    throw InvalidInput(file, 0, "kind", "must be \"hexapod\" or \"serial\", not '" + m.kind + "'");
  }
  if (m.kind == "hexapod") {
    m.geometry.base_joints_mm = Points6x3(doc, "base_joints_mm", file);
    m.geometry.platform_joints_mm = Points6x3(doc, "platform_joints_mm", file);
    if (doc.contains("strut_offset_mm")) {
      const json& o = doc["strut_offset_mm"];
      if (!o.is_array() || o.size() != 6) {
        throw InvalidInput(file, 0, "strut_offset_mm", "must be an array of 6 numbers");
      }
      for (std::size_t j = 0; j < 6; ++j) {
        m.geometry.strut_offset_mm[j] =
            Number(o[j], file, "strut_offset_mm[" + std::to_string(j) + "]");
      }
    }
    for (int j = 0; j < 6; ++j) {
      for (int k = j + 1; k < 6; ++k) {
        if ((m.geometry.base_joints_mm[j] - m.geometry.base_joints_mm[k]).norm() < 1e-6) {
          throw InvalidInput(file, 0, "base_joints_mm[" + std::to_string(k) + "]",
                             "coincides with base joint " + std::to_string(j));
        }
        if ((m.geometry.platform_joints_mm[j] - m.geometry.platform_joints_mm[k]).norm() < 1e-6) {
          throw InvalidInput(file, 0, "platform_joints_mm[" + std::to_string(k) + "]",
                             "coincides with platform joint " + std::to_string(j));
        }
      }
    }
    m.physics = ParseMachinePhysics(doc, file);
    m.effects = ParseMachineEffects(doc, file);
  }
  return m;
}

MachineDefinition ParseHexapodMachineJson(std::string_view bytes, const std::string& file) {
  auto m = ParseMachineJson(bytes, file);
  if (m.kind != "hexapod") throw InvalidInput(file, 0, "kind", "a hexapod machine is required");
  return m;
}

std::string WriteMachineJson(const MachineDefinition& machine) {
  json doc = json::object();
  if (!machine.source_json.empty()) {
    doc = ParseJsonTextOrDiscarded(machine.source_json);
    if (!doc.is_object()) doc = json::object();
  }
  doc["format"] = kMachineFormat;
  doc["machine_id"] = machine.machine_id;
  doc["kind"] = machine.kind.empty() ? std::string("hexapod") : machine.kind;
  if (doc["kind"] == "hexapod") {
    json base = json::array(), plat = json::array(), off = json::array();
    for (int j = 0; j < 6; ++j) {
      const auto& q = machine.geometry.base_joints_mm[j];
      const auto& p = machine.geometry.platform_joints_mm[j];
      base.push_back({q.x(), q.y(), q.z()});
      plat.push_back({p.x(), p.y(), p.z()});
      off.push_back(machine.geometry.strut_offset_mm[j]);
    }
    doc["base_joints_mm"] = base;
    doc["platform_joints_mm"] = plat;
    doc["strut_offset_mm"] = off;
    if (!machine.effects.empty()) doc["effects"] = MachineEffectsJson(machine.effects);
  }
  return doc.dump(2) + "\n";
}

}  // namespace km::ingest
