// The registry's linear-fit columns (RadialBasis): a model's closed form when it has one,
// otherwise automatic differentiation with ceres::Jet dual parts on the linear parameters.
#include <ceres/jet.h>

#include "analysis/core/errors.h"
#include "analysis/serial_effects/registry.h"

namespace km::serial_effects {

namespace {

// Columns of one model: its closed-form LinearBasis when it has one (one trigonometric
// evaluation for all columns), otherwise the Jet dual parts of the linear parameters.
template <typename M>
void BasisOf(const EffectContext& ctx, const Angle<double>& a, const double* shape,
             double* columns) {
  if constexpr (HasLinearBasis<M>) {
    ClosedFormBasis<M>(ctx, a, shape, columns);
  } else {
    using J = ceres::Jet<double, kMaxLinearParams>;
    J p[8];
    for (int j = 0; j < M::kNumParams; ++j) {
      p[j] = j < M::kNumLinear ? J(0.0, j) : J(shape[j - M::kNumLinear]);
    }
    const Angle<J> aj{J(a.theta), J(a.c), J(a.s)};
    J e[2];
    M::template PositionError<J>(ctx, aj, p, e);
    for (int j = 0; j < M::kNumLinear; ++j) columns[j] = e[0].v[j] * a.c + e[1].v[j] * a.s;
  }
}

}  // namespace

void RadialBasis(EffectId id, const EffectContext& ctx, const Angle<double>& a, const double* shape,
                 double* columns) {
  switch (id) {
#define KM_EFFECT_BASIS(eid, type)         \
  case EffectId::eid:                      \
    BasisOf<type>(ctx, a, shape, columns); \
    return;
    KM_SERIAL_EFFECT_LIST(KM_EFFECT_BASIS)
#undef KM_EFFECT_BASIS
    default:
      throw InvalidInput("unknown effect id");
  }
}

}  // namespace km::serial_effects
