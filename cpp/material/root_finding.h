#pragma once

#include <cmath>
#include <utility>

namespace muscle
{

struct RootResult
{
  double x = 0;
  int iterations = 0;
  bool converged = false;
};

/// Newton's method kept inside a bracket [lo, hi] of an increasing function
/// (f(lo) <= 0 <= f(hi)), as in Numerical Recipes' rtsafe: a step that leaves
/// the bracket, or is not at least half as short as the step before last, is
/// replaced by bisection, so the iteration cannot diverge and converges
/// quadratically once Newton takes over.
///
/// `f(x)` returns {f, f'}.  Stops when the step is below
/// `rtol * max(1, |x|)` or f vanishes.
template <typename Function>
RootResult bracketed_newton(Function&& f, double lo, double hi, double x0,
                            double rtol = 1e-15, int max_iterations = 200)
{
  RootResult r;
  double x = (x0 > lo and x0 < hi) ? x0 : 0.5 * (lo + hi);
  double dx = hi - lo, dx_before = dx;
  for (r.iterations = 1; r.iterations <= max_iterations; ++r.iterations)
  {
    const auto [fx, dfx] = f(x);
    if (!std::isfinite(fx))
    {
      // overflow far out in the bracket: the root lies below x
      hi = x;
      x = 0.5 * (lo + hi);
      continue;
    }
    if (fx == 0)
    {
      r.x = x;
      r.converged = true;
      return r;
    }
    (fx < 0 ? lo : hi) = x;
    const double newton = x - fx / dfx;
    if (std::abs(newton - x) <= rtol * std::max(1.0, std::abs(x)))
    {
      // f is at round-off level here; bisecting the stale bracket would only
      // chase noise
      r.x = newton;
      r.converged = true;
      return r;
    }
    dx_before = dx;
    if (!(newton > lo and newton < hi) or std::abs(2 * fx) > std::abs(dx_before * dfx))
    {
      dx = 0.5 * (hi - lo);
      x = lo + dx;
    }
    else
    {
      dx = x - newton;
      x = newton;
    }
    if (std::abs(dx) <= rtol * std::max(1.0, std::abs(x)))
    {
      r.x = x;
      r.converged = true;
      return r;
    }
  }
  r.x = x;
  return r;
}

} // namespace muscle
