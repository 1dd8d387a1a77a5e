#pragma once
// The finite differences the tests compare derivatives with: one place, so a
// step or an order is chosen once.
#include <vector>

namespace muscle::testing
{
/// Fourth-order central difference of a scalar f at 0 with step h.
template <typename F>
double central(F&& f, double h)
{
  return (-f(2 * h) + 8 * f(h) - 8 * f(-h) + f(-2 * h)) / (12 * h);
}

/// Fourth-order central difference of f at x with step h.
template <typename F>
double central_at(F&& f, double x, double h)
{
  return central([&](double d) { return f(x + d); }, h);
}

/// Second-order central difference of a vector-valued f at 0, component-wise
/// (one pair of evaluations: f may be a whole assembly).
template <typename F>
std::vector<double> central_vector(F&& f, double h)
{
  const std::vector<double> plus = f(h), minus = f(-h);
  std::vector<double> d(plus.size());
  for (std::size_t i = 0; i < d.size(); ++i)
    d[i] = (plus[i] - minus[i]) / (2 * h);
  return d;
}
} // namespace muscle::testing
