#pragma once

// What the files of the fit share and fit.h does not offer: the problem in
// scaled variables, the parameters' admissible bounds, and number formatting
// for messages and reports.
#include "fit/fit.h"

#include <cstdio>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace muscle::fit::detail
{

constexpr double inf = std::numeric_limits<double>::infinity();

/// `v` printed with a printf format, e.g. fmt("%g", v).
inline std::string fmt(const char* format, double v)
{
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, v);
  return buffer;
}

/// The spec of a parameter of `model`; InputError with did-you-mean if none.
const ParameterSpec& spec_of(const Model& model, const std::string& name);

/// The fit problem in scaled variables x_j = p_j / scale_j.
class Problem
{
public:
  Problem(const ParameterSet& start, const std::vector<DataPoint>& data,
          std::vector<std::string> free, std::vector<double> sqrt_weights);

  std::size_t rows() const { return _data.size(); }
  std::size_t cols() const { return _free.size(); }
  double scale(std::size_t j) const { return _scale[j]; }

  ParameterSet parameters(const double* x) const;

  /// False if the parameters are not admissible or P_exact fails.
  bool residuals(const double* x, double* r) const;

  /// Central differences (one-sided at a bound) in the scaled variables.
  bool jacobian(const double* x, const std::vector<double>& lower,
                const std::vector<double>& upper, double* J) const;

  std::vector<double> lower, upper; // scaled bounds

private:
  ParameterSet _base;
  const std::vector<DataPoint>& _data;
  std::vector<std::string> _free;
  std::vector<double> _sqrt_weights;
  std::vector<double> _scale;
};

// parameter_bounds.cpp

/// InputError for an unknown or repeated free parameter, or bounds of a
/// parameter that is not free or that are empty.
void check_free_and_bounds(const ParameterSet& start, const std::vector<std::string>& free,
                           const std::map<std::string, Bounds>& bounds);

/// The start values the fit begins from: `start`, or for a twitch-train law
/// with N_a free, `start` with P_opt derived again (InputError if P_opt was
/// set to another value, which would make N_a ineffective).
ParameterSet start_values(const ParameterSet& start, const std::vector<std::string>& free);

/// Sets the problem's scaled bounds (the admissible range intersected with
/// `bounds`) and returns the scaled start point, `start` inside its bounds.
std::vector<double> scaled_start(Problem& problem, const ParameterSet& start,
                                 const std::vector<std::string>& free,
                                 const std::map<std::string, Bounds>& bounds);

// identifiability.cpp

/// Row factors for analyse_identifiability: 1/(sqrt(weight) x RMS of the
/// curve's data x sqrt(points)); 0 for rows of weight 0.
std::vector<double> row_scales(const std::vector<DataPoint>& data,
                               const std::vector<double>& sqrt_weights);

// error_measures.cpp

/// The error measures of each curve of the fitted model against the data.
std::vector<CurveErrors> curve_errors(const std::vector<DataPoint>& data,
                                      const std::vector<double>& model,
                                      const std::map<CurveKey, double>& weights);

} // namespace muscle::fit::detail
