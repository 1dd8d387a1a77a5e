// Which parameters are fitted, where they start, and the range each may take:
// the law's admissible range intersected with the user's bounds.
#include "fit/fit_internal.h"

#include <common/errors.h>

#include <algorithm>
#include <cmath>

namespace muscle::fit
{

std::vector<std::string> default_free_parameters(const Model& model)
{
  const auto& names = model.law().fit_parameters;
  return {names.begin(), names.end()};
}

namespace detail
{
namespace
{
/// Open admissible bounds are moved inside by a small margin.
Bounds admissible(const ParameterSpec& s, double scale)
{
  Bounds b{s.lower, s.upper};
  if (std::isfinite(b.lower) and s.lower_open)
    b.lower += 1e-9 * std::max(std::abs(b.lower), scale);
  if (std::isfinite(b.upper) and s.upper_open)
    b.upper -= 1e-9 * std::max(std::abs(b.upper), scale);
  return b;
}
} // namespace

const ParameterSpec& spec_of(const Model& model, const std::string& name)
{
  for (const ParameterSpec& s : parameter_specs(model))
    if (s.name == name)
      return s;
  (void)ParameterSet{model}[name]; // throws with did-you-mean
  throw InputError("unknown parameter " + name);
}

void check_free_and_bounds(const ParameterSet& start, const std::vector<std::string>& free,
                           const std::map<std::string, Bounds>& bounds)
{
  for (std::size_t j = 0; j < free.size(); ++j)
  {
    (void)start[free[j]]; // unknown name: InputError with suggestion
    for (std::size_t k = 0; k < j; ++k)
      if (free[k] == free[j])
        throw InputError("parameter " + free[j] + " is listed twice as free");
  }
  for (const auto& [name, b] : bounds)
  {
    (void)start[name];
    if (std::find(free.begin(), free.end(), name) == free.end())
      throw InputError("bounds given for " + name + ", which is not free; free: "
                       + join(free));
    if (!(b.lower < b.upper))
      throw InputError("bounds of " + name + ": lower " + fmt("%g", b.lower)
                       + " must be below upper " + fmt("%g", b.upper));
  }
}

ParameterSet start_values(const ParameterSet& start, const std::vector<std::string>& free)
{
  const Model model = start.model();
  if (!uses_twitch_train(model) or !start.explicitly_set("P_opt")
      or std::find(free.begin(), free.end(), "N_a") == free.end())
    return start;
  // P_opt follows N_a unless set explicitly; a set value equal to the derived
  // one (a parameter file written by this tool) is taken as derived.
  ParameterSet derived(model);
  for (const std::string& name : start.names())
    if (name != "P_opt")
      derived.set(name, start[name]);
  if (std::abs(derived["P_opt"] - start["P_opt"]) > 1e-9 * std::abs(start["P_opt"]))
    throw InputError("N_a is free but P_opt is set explicitly (to a value other than "
                     "the twitch train's tetanic level), so N_a has no effect; fit P_opt "
                     "instead (--free ...,P_opt) or do not set P_opt");
  return derived;
}

std::vector<double> scaled_start(Problem& problem, const ParameterSet& start,
                                 const std::vector<std::string>& free,
                                 const std::map<std::string, Bounds>& bounds)
{
  const std::size_t n = problem.cols();
  std::vector<double> x(n);
  problem.lower.resize(n);
  problem.upper.resize(n);
  for (std::size_t j = 0; j < n; ++j)
  {
    const std::string& name = free[j];
    const double s = problem.scale(j);
    Bounds b = admissible(spec_of(start.model(), name), s);
    if (auto it = bounds.find(name); it != bounds.end())
    {
      b.lower = std::max(b.lower, it->second.lower);
      b.upper = std::min(b.upper, it->second.upper);
    }
    x[j] = start[name] / s;
    problem.lower[j] = b.lower / s;
    problem.upper[j] = b.upper / s;
    if (!(x[j] >= problem.lower[j] and x[j] <= problem.upper[j]))
      throw InputError("start value " + name + "=" + fmt("%g", start[name])
                       + " lies outside its bounds [" + fmt("%g", b.lower) + ", "
                       + fmt("%g", b.upper) + "]");
  }
  return x;
}

} // namespace detail
} // namespace muscle::fit
