#include "analysis/core/minimize_1d.h"

#include <cmath>

namespace km {
namespace {

// The three best points so far: x the best, w the second, v the previous w.
struct Points {
  double x, w, v, fx, fw, fv;
  void Take(double u, double fu, double& a, double& b) {
    if (fu <= fx) {
      (u >= x ? a : b) = x;
      v = w, fv = fw, w = x, fw = fx, x = u, fx = fu;
      return;
    }
    (u < x ? a : b) = u;
    if (fu <= fw || w == x) {
      v = w, fv = fw, w = u, fw = fu;
    } else if (fu <= fv || v == x || v == w) {
      v = u, fv = fu;
    }
  }
};

}  // namespace

Minimum1d BrentMinimize(const std::function<double(double)>& f, double a, double b, double tol,
                        int max_evaluations) {
  const double golden = 0.5 * (3.0 - std::sqrt(5.0));
  const double x0 = a + golden * (b - a), f0 = f(x0);
  Points p{x0, x0, x0, f0, f0, f0};
  int evaluations = 1;
  double d = 0.0, e = 0.0;  // the last step and the one before it
  while (evaluations < max_evaluations) {
    const double xm = 0.5 * (a + b), tol2 = 2.0 * tol;
    if (std::abs(p.x - xm) <= tol2 - 0.5 * (b - a)) break;
    bool parabolic = false;
    if (std::abs(e) > tol) {
      // The parabola through x, w and v: its vertex at x + p/q.
      const double r = (p.x - p.w) * (p.fx - p.fv);
      double q = (p.x - p.v) * (p.fx - p.fw);
      double num = (p.x - p.v) * q - (p.x - p.w) * r;
      q = 2.0 * (q - r);
      if (q > 0.0) num = -num;
      q = std::abs(q);
      const double before = e;
      e = d;
      // Trusted when it moves less than half the step before last and stays in the bracket.
      if (std::abs(num) < std::abs(0.5 * q * before) && num > q * (a - p.x) &&
          num < q * (b - p.x)) {
        d = num / q;
        const double u = p.x + d;
        if (u - a < tol2 || b - u < tol2) d = std::copysign(tol, xm - p.x);
        parabolic = true;
      }
    }
    if (!parabolic) {
      e = p.x >= xm ? a - p.x : b - p.x;
      d = golden * e;
    }
    const double u = std::abs(d) >= tol ? p.x + d : p.x + std::copysign(tol, d);
    const double fu = f(u);
    ++evaluations;
    p.Take(u, fu, a, b);
  }
  return {p.x, p.fx, evaluations};
}

}  // namespace km
