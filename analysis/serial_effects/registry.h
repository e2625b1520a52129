// Registry of the serial-machine error effects seen by a DBB circular test (docs/formats.md §4).
// Generated from KM_SERIAL_EFFECT_LIST (effect_list.h), COLMAP sensor/models.h style: every
// effect has an id, a name (axis letter filled in from the plane), parameter names, a unit for
// its reported value and a templated forward model of the machine position error e(θ) whose
// radial projection is the DBB signature (see effect_model.h for the conventions).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/serial_effects/effect_list.h"

namespace km::serial_effects {

enum class EffectId {
#define KM_EFFECT_ENUM(id, type) id,
  KM_SERIAL_EFFECT_LIST(KM_EFFECT_ENUM)
#undef KM_EFFECT_ENUM
      kCount
};

struct EffectInfo {
  EffectId id;
  std::string base_name;  // e.g. "backlash"
  int axis = -1;          // −1, 0 (first plane axis), 1 (second)
  int num_params = 0;
  int num_linear = 0;
  std::vector<std::string> param_names;
  std::string unit;
  bool in_form = true;     // counts in the circularity (false: centre, radius, servo-lag radius)
  bool linear_fit = true;  // identified by the linear least-squares fit
  std::vector<double> default_shape;
};

const std::vector<EffectInfo>& AllEffects();
const EffectInfo& Info(EffectId id);

// Contract name for a plane with axis letters (first, second), e.g. 'x','y' → "backlash_x".
std::string EffectName(EffectId id, char first_axis = 'x', char second_axis = 'y');
// Inverse of EffectName for the same axis letters; false when unknown.
bool EffectIdFromName(const std::string& name, char first_axis, char second_axis, EffectId* id);

// Position error e = (e_u, e_v) in µm at commanded angle θ (rad).
void PositionError(EffectId id, const EffectContext& ctx, double theta, const double* params,
                   double e[2]);
// Radial signature Δr(θ) = e_u cos θ + e_v sin θ (µm).
double RadialSignature(EffectId id, const EffectContext& ctx, double theta, const double* params);
double RadialSignature(EffectId id, const EffectContext& ctx, const Angle<double>& a,
                       const double* params);

// Radial signatures of the linear parameters at once (the columns of a linear fit): for the
// shape parameters `shape` (num_params − num_linear values), columns[j] = ∂Δr/∂p_j, j <
// num_linear. A model may give them in closed form (a static LinearBasis(ctx, angle, shape,
// e[j][2]) with the position-error columns, e.g. cyclic_error.h); otherwise they are evaluated
// in one pass with ceres::Jet dual parts on the linear parameters.
constexpr int kMaxLinearParams = 2;
void RadialBasis(EffectId id, const EffectContext& ctx, const Angle<double>& a, const double* shape,
                 double* columns);

// Whether model M gives its linear-parameter columns in closed form, and those columns (the
// radial projection of M::LinearBasis) — what RadialBasis returns for such a model, inlined in
// a loop over samples.
template <typename M>
concept HasLinearBasis = requires(const EffectContext& ctx, const Angle<double>& a,
                                  const double* shape, double (*e)[2]) {
  M::LinearBasis(ctx, a, shape, e);
};
template <HasLinearBasis M>
inline void ClosedFormBasis(const EffectContext& ctx, const Angle<double>& a, const double* shape,
                            double* columns) {
  double e[kMaxLinearParams][2];
  M::LinearBasis(ctx, a, shape, e);
  for (int j = 0; j < M::kNumLinear; ++j) columns[j] = e[j][0] * a.c + e[j][1] * a.s;
}

// Reported value (docs/formats.md §4 unit) and its jacobian with respect to the parameters.
std::vector<double> Value(EffectId id, const EffectContext& ctx, const double* params);
Eigen::MatrixXd ValueJacobian(EffectId id, const EffectContext& ctx, const double* params);

[[noreturn]] void ThrowUnknownEffect();

// Calls f.template operator()<Model>() with the model type of `id` (effect_list.h): one
// dispatch for a whole loop over samples, e.g. a signature column. Throws km::InvalidInput for
// an unknown id.
template <typename F>
void VisitEffect(EffectId id, F&& f) {
  switch (id) {
#define KM_EFFECT_VISIT(eid, type) \
  case EffectId::eid:              \
    f.template operator()<type>(); \
    return;
    KM_SERIAL_EFFECT_LIST(KM_EFFECT_VISIT)
#undef KM_EFFECT_VISIT
    default:
      ThrowUnknownEffect();
  }
}

// Templated position error for automatic differentiation (T = double or ceres::Jet).
template <typename T>
void PositionErrorT(EffectId id, const EffectContext& ctx, const Angle<T>& a, const T* params,
                    T* e) {
  switch (id) {
#define KM_EFFECT_CASE(eid, type)                       \
  case EffectId::eid:                                   \
    type::template PositionError<T>(ctx, a, params, e); \
    return;
    KM_SERIAL_EFFECT_LIST(KM_EFFECT_CASE)
#undef KM_EFFECT_CASE
    default:
      e[0] = T(0.0);
      e[1] = T(0.0);
  }
}

}  // namespace km::serial_effects
