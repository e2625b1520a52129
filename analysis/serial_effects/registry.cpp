#include "analysis/serial_effects/registry.h"

#include <cmath>

#include "analysis/core/errors.h"

namespace km::serial_effects {

namespace {

template <typename M>
EffectInfo MakeInfo(EffectId id) {
  EffectInfo info;
  info.id = id;
  info.base_name = M::kBaseName;
  info.axis = M::kAxis;
  info.num_params = M::kNumParams;
  info.num_linear = M::kNumLinear;
  for (int i = 0; i < M::kNumParams; ++i) info.param_names.emplace_back(M::kParamNames[i]);
  info.unit = M::kUnit;
  info.in_form = M::kInForm;
  info.linear_fit = M::kLinearFit;
  info.default_shape = M::DefaultShape();
  return info;
}

template <typename M>
constexpr bool FitsBasis() {
  return M::kNumLinear <= kMaxLinearParams && M::kNumParams <= 8;
}
#define KM_EFFECT_CHECK(eid, type) \
  static_assert(FitsBasis<type>(), "too many parameters for RadialBasis");
KM_SERIAL_EFFECT_LIST(KM_EFFECT_CHECK)
#undef KM_EFFECT_CHECK

std::vector<EffectInfo> BuildInfos() {
  std::vector<EffectInfo> v;
#define KM_EFFECT_INFO(eid, type) v.push_back(MakeInfo<type>(EffectId::eid));
  KM_SERIAL_EFFECT_LIST(KM_EFFECT_INFO)
#undef KM_EFFECT_INFO
  return v;
}

}  // namespace

void ThrowUnknownEffect() {
  throw InvalidInput("unknown effect id");
}

const std::vector<EffectInfo>& AllEffects() {
  static const std::vector<EffectInfo> infos = BuildInfos();
  return infos;
}

const EffectInfo& Info(EffectId id) {
  const auto i = static_cast<std::size_t>(id);
  if (i >= AllEffects().size()) throw InvalidInput("unknown effect id");
  return AllEffects()[i];
}

std::string EffectName(EffectId id, char first_axis, char second_axis) {
  const EffectInfo& info = Info(id);
  if (info.axis < 0) return info.base_name;
  return info.base_name + "_" + (info.axis == 0 ? first_axis : second_axis);
}

bool EffectIdFromName(const std::string& name, char first_axis, char second_axis, EffectId* id) {
  for (const auto& info : AllEffects()) {
    if (EffectName(info.id, first_axis, second_axis) == name) {
      *id = info.id;
      return true;
    }
  }
  return false;
}

void PositionError(EffectId id, const EffectContext& ctx, double theta, const double* params,
                   double e[2]) {
  PositionErrorT<double>(id, ctx, MakeAngle(theta), params, e);
}

double RadialSignature(EffectId id, const EffectContext& ctx, double theta, const double* params) {
  return RadialSignature(id, ctx, MakeAngle(theta), params);
}

double RadialSignature(EffectId id, const EffectContext& ctx, const Angle<double>& a,
                       const double* params) {
  double e[2];
  PositionErrorT<double>(id, ctx, a, params, e);
  return e[0] * a.c + e[1] * a.s;
}

std::vector<double> Value(EffectId id, const EffectContext& ctx, const double* params) {
  switch (id) {
#define KM_EFFECT_VALUE(eid, type) \
  case EffectId::eid:              \
    return type::Value(ctx, params);
    KM_SERIAL_EFFECT_LIST(KM_EFFECT_VALUE)
#undef KM_EFFECT_VALUE
    default:
      throw InvalidInput("unknown effect id");
  }
}

Eigen::MatrixXd ValueJacobian(EffectId id, const EffectContext& ctx, const double* params) {
  switch (id) {
#define KM_EFFECT_VJ(eid, type) \
  case EffectId::eid:           \
    return type::ValueJacobian(ctx, params);
    KM_SERIAL_EFFECT_LIST(KM_EFFECT_VJ)
#undef KM_EFFECT_VJ
    default:
      throw InvalidInput("unknown effect id");
  }
}

}  // namespace km::serial_effects
