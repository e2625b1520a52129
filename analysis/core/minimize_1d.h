// The minimum of a function of one variable in a bracket, by Brent's method (R. P. Brent,
// "Algorithms for Minimization without Derivatives", 1973, ch. 5): parabolic interpolation
// through the three best points where it is trusted, a golden-section step otherwise. On a
// smooth minimum it converges superlinearly (an objective costing a pass over every sample then
// needs about a third of the evaluations of a golden-section search to the same resolution); it
// is never slower than golden section by more than a step.
#pragma once

#include <functional>

namespace km {

struct Minimum1d {
  double x = 0.0;   // the abscissa of the least value found
  double fx = 0.0;  // the value there
  int evaluations = 0;
};

// Minimises f over [a, b] (a < b) until the minimum is bracketed within about ±2 tol (tol > 0,
// absolute, in x) or after max_evaluations. f is not evaluated at a or b.
Minimum1d BrentMinimize(const std::function<double(double)>& f, double a, double b, double tol,
                        int max_evaluations = 200);

}  // namespace km
