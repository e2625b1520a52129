#include "ingest/machine_physics.h"

#include <cmath>

#include "analysis/core/errors.h"

namespace km::ingest {
namespace {

using nlohmann::json;

double Num(const json& block, const char* key, const std::string& file, const std::string& field,
           double fallback, bool non_negative) {
  if (!block.contains(key)) return fallback;
  const json& v = block[key];
  const std::string f = field + "." + key;
  if (!v.is_number()) throw InvalidInput(file, 0, f, "must be a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw InvalidInput(file, 0, f, "must be finite");
  if (non_negative && d < 0.0) throw InvalidInput(file, 0, f, "must not be negative");
  return d;
}

Eigen::Vector3d Vec3(const json& block, const char* key, const std::string& file,
                     const std::string& field, const Eigen::Vector3d& fallback) {
  if (!block.contains(key)) return fallback;
  const json& v = block[key];
  const std::string f = field + "." + key;
  if (!v.is_array() || v.size() != 3) throw InvalidInput(file, 0, f, "must be 3 numbers");
  Eigen::Vector3d out;
  for (std::size_t c = 0; c < 3; ++c) {
    if (!v[c].is_number() || !std::isfinite(v[c].get<double>()))
      throw InvalidInput(file, 0, f + "[" + std::to_string(c) + "]", "must be a finite number");
    out[static_cast<Eigen::Index>(c)] = v[c].get<double>();
  }
  return out;
}

void ParseGravity(const json& g, const std::string& file, hexapod::MachinePhysics& m) {
  const std::string f = "gravity";
  if (!g.is_object()) throw InvalidInput(file, 0, f, "must be an object");
  m.has_gravity = true;
  m.g_m_s2 = 1e-3 * Vec3(g, "g_mm_s2", file, f, Eigen::Vector3d(0, 0, -9806.65));
  m.platform_mass_kg = Num(g, "platform_mass_kg", file, f, 0.0, true);
  m.platform_cog_mm = Vec3(g, "platform_cog_mm", file, f, Eigen::Vector3d::Zero());
  m.ball_screw_mass_kg = Num(g, "ball_screw_mass_kg", file, f, 0.0, true);
  m.joint_mass_kg = Num(g, "joint_mass_kg", file, f, 0.0, true);
  m.motor_mass_kg = Num(g, "motor_mass_kg", file, f, 0.0, true);
  m.motor_offset_mm = Num(g, "motor_offset_mm", file, f, 0.0, true);
  m.platform_joint_length_mm = Num(g, "platform_joint_length_mm", file, f, 0.0, true);
  m.ball_screw_length_mm = Num(g, "ball_screw_length_mm", file, f, 1.0, true);
  if (!(m.ball_screw_length_mm > 0.0))
    throw InvalidInput(file, 0, f + ".ball_screw_length_mm", "must be positive");
  m.strut_equivalent_mass_kg = Num(g, "strut_equivalent_mass_kg", file, f, 0.0, true);
  m.compliance_screw_mm_per_N = Num(g, "compliance_screw_mm_per_N", file, f, 0.0, true);
  m.compliance_other_mm_per_N = Num(g, "compliance_other_mm_per_N", file, f, 0.0, true);
}

void ParseFriction(const json& fr, const std::string& file, hexapod::MachinePhysics& m) {
  const std::string f = "friction";
  if (!fr.is_object()) throw InvalidInput(file, 0, f, "must be an object");
  m.has_friction = true;
  if (fr.contains("screw_friction_N")) {
    const json& a = fr["screw_friction_N"];
    if (!a.is_array() || a.size() != 6)
      throw InvalidInput(file, 0, f + ".screw_friction_N", "must be 6 numbers");
    for (std::size_t j = 0; j < 6; ++j) {
      if (!a[j].is_number() || !std::isfinite(a[j].get<double>()) || a[j].get<double>() < 0.0)
        throw InvalidInput(file, 0, f + ".screw_friction_N[" + std::to_string(j) + "]",
                           "must be a finite number >= 0");
      m.screw_friction_N[j] = a[j].get<double>();
    }
  }
  m.base_joint_torque_Nm = Num(fr, "base_joint_torque_Nm", file, f, 0.0, true);
  m.base_joint_torque_per_N_m = Num(fr, "base_joint_torque_per_N_m", file, f, 0.0, true);
}

}  // namespace

std::optional<hexapod::MachinePhysics> ParseMachinePhysics(const json& doc,
                                                           const std::string& file) {
  if (!doc.contains("gravity") && !doc.contains("friction")) return std::nullopt;
  hexapod::MachinePhysics m;
  if (doc.contains("gravity")) ParseGravity(doc["gravity"], file, m);
  if (doc.contains("friction")) ParseFriction(doc["friction"], file, m);
  return m;
}

std::vector<MachineEffect> ParseMachineEffects(const json& doc, const std::string& file) {
  std::vector<MachineEffect> out;
  if (!doc.contains("effects")) return out;
  const json& list = doc["effects"];
  if (!list.is_array()) throw InvalidInput(file, 0, "effects", "must be an array");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string f = "effects[" + std::to_string(i) + "]";
    const json& e = list[i];
    if (!e.is_object() || !e.contains("effect") || !e["effect"].is_string())
      throw InvalidInput(file, 0, f + ".effect", "missing effect name");
    MachineEffect me;
    me.effect = e["effect"].get<std::string>();
    if (e.contains("parameters")) {
      if (!e["parameters"].is_object())
        throw InvalidInput(file, 0, f + ".parameters", "must be an object");
      for (const auto& [k, v] : e["parameters"].items()) {
        if (!v.is_number() || !std::isfinite(v.get<double>()))
          throw InvalidInput(file, 0, f + ".parameters." + k, "must be a finite number");
        me.parameters.emplace_back(k, v.get<double>());
      }
    }
    out.push_back(std::move(me));
  }
  return out;
}

json MachineEffectsJson(const std::vector<MachineEffect>& effects) {
  json list = json::array();
  for (const auto& e : effects) {
    json p = json::object();
    for (const auto& [k, v] : e.parameters) p[k] = v;
    list.push_back({{"effect", e.effect}, {"parameters", p}});
  }
  return list;
}

}  // namespace km::ingest
