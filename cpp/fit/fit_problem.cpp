// P_exact at the data, and the residuals of the fit and their Jacobian in
// variables scaled by the start values, so that the solver sees parameters of
// similar size.
#include "fit/fit_internal.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace muscle::fit
{

std::vector<double> model_stresses(const ParameterSet& p, const std::vector<DataPoint>& data)
{
  MaterialPointModel active(p), passive(p);
  active.set_time_factor(1);
  passive.set_time_factor(0);
  std::vector<double> out;
  out.reserve(data.size());
  for (const DataPoint& d : data)
    out.push_back(exact_response(d.state == MuscleState::active ? active : passive,
                                 d.load_case, d.control)
                      .stress);
  return out;
}

std::vector<double> model_curve(const ParameterSet& p, const CurveKey& key,
                                const std::vector<double>& controls)
{
  MaterialPointModel model(p);
  model.set_time_factor(key.state == MuscleState::active ? 1 : 0);
  std::vector<double> out;
  for (double s : controls)
    out.push_back(exact_response(model, key.load_case, s).stress);
  return out;
}

namespace detail
{

Problem::Problem(const ParameterSet& start, const std::vector<DataPoint>& data,
                 std::vector<std::string> free, std::vector<double> sqrt_weights)
    : _base(start), _data(data), _free(std::move(free)), _sqrt_weights(std::move(sqrt_weights))
{
  for (const std::string& name : _free)
  {
    const double v = start[name];
    double s = std::abs(v);
    if (!(s > 0))
      s = std::abs(spec_of(start.model(), name).preset);
    if (!(s > 0))
      s = 1;
    _scale.push_back(s);
  }
}

ParameterSet Problem::parameters(const double* x) const
{
  ParameterSet p = _base;
  for (std::size_t j = 0; j < _free.size(); ++j)
    p.set(_free[j], x[j] * _scale[j]);
  return p;
}

bool Problem::residuals(const double* x, double* r) const
{
  try
  {
    const ParameterSet p = parameters(x);
    p.validate();
    const std::vector<double> m = model_stresses(p, _data);
    for (std::size_t i = 0; i < _data.size(); ++i)
    {
      r[i] = _sqrt_weights[i] * (m[i] - _data[i].stress);
      if (!std::isfinite(r[i]))
        return false;
    }
    return true;
  }
  catch (const std::exception& e)
  {
    if (std::getenv("MUSCLE_FIT_DEBUG"))
      std::fprintf(stderr, "residual evaluation failed: %s\n", e.what());
    return false;
  }
}

bool Problem::jacobian(const double* x, const std::vector<double>& lower,
                       const std::vector<double>& upper, double* J) const
{
  const std::size_t m = rows(), n = cols();
  std::vector<double> xp(x, x + n), rp(m), rm(m), r0;
  for (std::size_t j = 0; j < n; ++j)
  {
    const double h = 1e-6 * std::max(std::abs(x[j]), 1e-3);
    double hi = x[j] + h, lo = x[j] - h;
    if (hi > upper[j])
      hi = x[j];
    if (lo < lower[j])
      lo = x[j];
    if (hi == lo)
      return false;
    xp[j] = hi;
    bool ok = residuals(xp.data(), rp.data());
    xp[j] = lo;
    ok = ok and residuals(xp.data(), rm.data());
    xp[j] = x[j];
    if (!ok)
    {
      // a kink or the edge of the admissible set: try one-sided
      if (r0.empty())
      {
        r0.resize(m);
        if (!residuals(x, r0.data()))
          return false;
      }
      xp[j] = x[j] + h;
      if (xp[j] <= upper[j] and residuals(xp.data(), rp.data()))
      {
        lo = x[j];
        hi = xp[j];
        rm = r0;
      }
      else
      {
        xp[j] = x[j] - h;
        if (xp[j] < lower[j] or !residuals(xp.data(), rm.data()))
          return false;
        lo = xp[j];
        hi = x[j];
        rp = r0;
      }
      xp[j] = x[j];
    }
    for (std::size_t i = 0; i < m; ++i)
      J[i * n + j] = (rp[i] - rm[i]) / (hi - lo);
  }
  return true;
}

} // namespace detail
} // namespace muscle::fit
