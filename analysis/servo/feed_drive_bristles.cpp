// The bristle force of eqs. 4.1–4.2 along the measured motion at the reversals, and its
// derivatives in the LuGre parameters carried through the same exact steps (forward mode), for
// the Jacobian of the LuGre fit (feed_drive_lugre.cpp): one pass gives the force and all its
// derivatives, where differences would need a pass a parameter. The force is computed with the
// same arithmetic with and without the derivatives.
#include <cmath>

#include "analysis/servo/feed_drive_detail.h"

namespace km::servo::detail {
namespace {

// g(v) of the Stribeck curve and, when asked, its derivatives in ln F_s, ln v_s and ln δ.
struct Rise {
  double g = 0.0;
  double d_fs = 0.0, d_vs = 0.0, d_delta = 0.0;
};

Rise RiseAt(const LugreParameters& p, double v, bool derivatives, bool exponent) {
  const double u = std::abs(v / p.vs_mm_s);
  double shape = 0.0, by_vs = 0.0, by_delta = 0.0;  // S and its derivatives in ln v_s, ln δ
  if (p.stribeck_form == LugreParameters::Form::kLorentzian) {
    shape = 1.0 / (1.0 + u * u);
    by_vs = 2.0 * u * u * shape * shape;
  } else {
    const double delta = p.stribeck_exponent;
    const double power = delta == 2.0 ? u * u : std::pow(u, delta);
    shape = std::exp(-power);
    by_vs = delta * power * shape;
    if (derivatives && exponent && u > 0.0) by_delta = -delta * power * std::log(u) * shape;
  }
  Rise r;
  r.g = p.Fc_N + (p.Fs_N - p.Fc_N) * shape;
  if (derivatives) {
    r.d_fs = p.Fs_N * shape;
    r.d_vs = (p.Fs_N - p.Fc_N) * by_vs;
    r.d_delta = (p.Fs_N - p.Fc_N) * by_delta;
  }
  return r;
}

// dg/dθ for θ = ln F_s, ln v_s, ln σ0, ln δ (σ0 does not enter g).
std::array<double, kBristleParams> RiseDerivatives(const Rise& r) {
  return {r.d_fs, r.d_vs, 0.0, r.d_delta};
}
constexpr int kSigma0 = 2;  // ln σ0 among the bristle parameters

struct State {
  double z = 0.0;                           // µm
  std::array<double, kBristleParams> dz{};  // dz/dθ
};

// One exact step of eq. 4.1 at constant speed v (mm/s) over h seconds, with the derivatives.
void Step(const LugreParameters& p, State& st, double v, double h, bool derivatives,
          bool exponent) {
  if (v == 0.0) return;  // standing: the bristles hold
  const double vu = 1e3 * v;
  const Rise rise = RiseAt(p, v, derivatives, exponent);
  const double rate = p.sigma0_N_per_um * std::abs(vu) / rise.g;  // 1/s
  if (!(rate > 0.0)) return;
  const double z_ss = vu / rate;  // sign(v) g / σ0
  const double e = std::exp(-rate * h);
  if (derivatives) {
    const auto dg = RiseDerivatives(rise);
    // d rate/dθ = rate (own − dg/g), d z_ss/dθ = sign(v) dg/σ0 − own z_ss: the divisions once.
    const double by_g = rate / rise.g, by_s0 = (v > 0.0 ? 1.0 : -1.0) / p.sigma0_N_per_um;
    const double lag = (st.z - z_ss) * h * e;
    for (int k = 0; k < kBristleParams; ++k) {
      const bool own = k == kSigma0;
      const double d_rate = (own ? rate : 0.0) - by_g * dg[k];
      const double d_zss = by_s0 * dg[k] - (own ? z_ss : 0.0);
      st.dz[k] = d_zss * (1.0 - e) + e * st.dz[k] - lag * d_rate;
    }
  }
  st.z = z_ss + (st.z - z_ss) * e;
}

}  // namespace

void BristleForce(const Strokes& s, const std::vector<Window>& ws, const LugreParameters& p,
                  Reading reading, std::vector<double>& out, std::vector<double>* damping,
                  std::vector<BristleDerivatives>* derivatives, bool exponent) {
  out.clear();
  if (damping) damping->clear();
  if (derivatives) derivatives->clear();
  const bool with = derivatives != nullptr;
  for (const auto& w : ws) {
    const double v0 = s.v[w.first];
    State st;
    {
      const Rise rise = RiseAt(p, v0, with, exponent);
      const double side = v0 > 0.0 ? 1.0 : -1.0;
      st.z = side * rise.g / p.sigma0_N_per_um;
      const auto dg = RiseDerivatives(rise);
      for (int k = 0; k < kBristleParams; ++k)
        st.dz[k] = side * dg[k] / p.sigma0_N_per_um - (k == kSigma0 ? st.z : 0.0);
    }
    for (std::size_t i = w.first; i <= w.last; ++i) {
      double v = s.v[i];
      if (i > w.first) {
        const double dt = s.t[i] - s.t[i - 1], mean = (s.x[i] - s.x[i - 1]) / dt;
        const bool standing = s.v[i - 1] == 0.0 && s.v[i] == 0.0 && mean == 0.0;
        if (standing) {
          v = 0.0;  // every sub-interval stands: z holds
        } else if (reading == Reading::kLinear) {
          const double shift = mean - 0.5 * (s.v[i - 1] + s.v[i]);
          for (int k = 0; k < kSubsteps; ++k) {
            const double u = (k + 0.5) / kSubsteps;
            Step(p, st, (1.0 - u) * s.v[i - 1] + u * s.v[i] + shift, dt / kSubsteps, with,
                 exponent);
          }
        } else {
          v = mean;
          Step(p, st, v, dt, with, exponent);
        }
      }
      const double vu = 1e3 * v;
      const Rise rise = RiseAt(p, v, with, exponent);
      const double zdot =
          v == 0.0 ? 0.0 : vu - p.sigma0_N_per_um * std::abs(vu) * st.z / rise.g;  // µm/s
      out.push_back(p.sigma0_N_per_um * st.z + p.sigma1_N_s_per_mm * 1e-3 * zdot);
      if (damping) damping->push_back(1e-3 * zdot);
      if (!with) continue;
      const double rate = v == 0.0 ? 0.0 : p.sigma0_N_per_um * std::abs(vu) / rise.g;
      const auto dg = RiseDerivatives(rise);
      BristleDerivatives d{};
      for (int k = 0; k < kBristleParams; ++k) {
        const double own = k == kSigma0 ? 1.0 : 0.0;
        const double d_rate = rate * (own - dg[k] / rise.g);
        const double d_zdot = v == 0.0 ? 0.0 : -(d_rate * st.z + rate * st.dz[k]);
        d[k] = own * p.sigma0_N_per_um * st.z + p.sigma0_N_per_um * st.dz[k] +
               p.sigma1_N_s_per_mm * 1e-3 * d_zdot;
      }
      derivatives->push_back(d);
    }
  }
}

}  // namespace km::servo::detail
