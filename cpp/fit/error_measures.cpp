// How far the model is from the data: the paper's relative error measures,
// per curve.
#include "fit/fit_internal.h"

#include <algorithm>
#include <cmath>

namespace muscle::fit
{

ErrorMeasures error_measures(const std::vector<double>& x, const std::vector<double>& xs)
{
  double dinf = 0, d1 = 0, d2 = 0, ninf = 0, n1 = 0, n2 = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
  {
    const double d = std::abs(x[i] - xs[i]);
    dinf = std::max(dinf, d);
    d1 += d;
    d2 += d * d;
    ninf = std::max(ninf, std::abs(xs[i]));
    n1 += std::abs(xs[i]);
    n2 += xs[i] * xs[i];
  }
  return {dinf / ninf, d1 / n1, std::sqrt(d2 / n2)};
}

namespace detail
{

std::vector<CurveErrors> curve_errors(const std::vector<DataPoint>& data,
                                      const std::vector<double>& model,
                                      const std::map<CurveKey, double>& weights)
{
  std::vector<CurveErrors> errors;
  for (const auto& [k, weight] : weights)
  {
    std::vector<double> xm, xs;
    for (std::size_t i = 0; i < data.size(); ++i)
      if (CurveKey{data[i].load_case, data[i].state} == k)
      {
        xm.push_back(model[i]);
        xs.push_back(data[i].stress);
      }
    errors.push_back({k, xm.size(), weight, error_measures(xm, xs)});
  }
  return errors;
}

} // namespace detail
} // namespace muscle::fit
