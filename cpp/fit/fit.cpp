// The fit itself: weighted residuals of the curves, bounded Levenberg-Marquardt
// (Ceres), and the solution's errors and identifiability.
#include "fit/fit_internal.h"

#include <common/errors.h>

#include <algorithm>
#include <ceres/ceres.h>
#include <cmath>
#include <glog/logging.h>
#include <optional>
#include <set>

namespace muscle::fit
{
namespace
{
using detail::fmt;
using detail::Problem;

class Cost : public ceres::CostFunction
{
public:
  explicit Cost(const Problem& problem) : _problem(problem)
  {
    set_num_residuals(static_cast<int>(problem.rows()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(problem.cols()));
  }
  bool Evaluate(double const* const* x, double* r, double** J) const override
  {
    if (!_problem.residuals(x[0], r))
      return false;
    if (J and J[0])
      return _problem.jacobian(x[0], _problem.lower, _problem.upper, J[0]);
    return true;
  }

private:
  const Problem& _problem;
};

double weight_of(const std::map<std::string, double>& weights, const CurveKey& k)
{
  const std::string c = muscle::to_string(k.load_case);
  if (auto it = weights.find(c + ":" + muscle::to_string(k.state)); it != weights.end())
    return it->second;
  if (auto it = weights.find(c); it != weights.end())
    return it->second;
  return 1;
}

/// InputError for a weight that is negative or not finite, or of a curve
/// absent from the data.
void check_weights(const std::map<std::string, double>& weights,
                   const std::set<CurveKey>& curves)
{
  for (const auto& [key, w] : weights)
  {
    if (!(w >= 0) or !std::isfinite(w))
      throw InputError("weight " + key + "=" + fmt("%g", w)
                       + " is not allowed: weights must be finite and >= 0");
    const auto colon = key.find(':');
    const LoadCase c = parse_load_case(key.substr(0, colon));
    std::optional<MuscleState> s;
    if (colon != std::string::npos)
      s = parse_state_name(key.substr(colon + 1));
    bool present = false;
    std::vector<std::string> names;
    for (const CurveKey& k : curves)
    {
      names.push_back(muscle::to_string(k.load_case) + ":" + muscle::to_string(k.state));
      present = present or (k.load_case == c and (!s or k.state == *s));
    }
    if (!present)
      throw InputError("weight for " + key + ", but the data have no such curve; curves: "
                       + join(names));
  }
}

/// The weight of each curve of the data, 1/peak^2 included with scale_curves.
std::map<CurveKey, double> curve_weights(const std::vector<DataPoint>& data,
                                         const FitOptions& options)
{
  std::set<CurveKey> curves;
  for (const DataPoint& d : data)
    curves.insert({d.load_case, d.state});
  check_weights(options.weights, curves);
  std::map<CurveKey, double> curve_weight;
  for (const CurveKey& k : curves)
    curve_weight[k] = weight_of(options.weights, k);
  if (options.scale_curves)
  {
    std::map<CurveKey, double> peak;
    for (const DataPoint& d : data)
      peak[{d.load_case, d.state}]
          = std::max(peak[{d.load_case, d.state}], std::abs(d.stress));
    for (auto& [k, w] : curve_weight)
    {
      if (!(peak[k] > 0))
        throw InputError("--scale-curves: the " + to_string(k)
                         + " data are all zero; nothing to scale by");
      w /= peak[k] * peak[k];
    }
  }
  return curve_weight;
}

ceres::Solver::Options solver_options(const FitOptions& options)
{
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = 1e-15;
  so.gradient_tolerance = 1e-16;
  so.parameter_tolerance = 1e-13;
  so.minimizer_progress_to_stdout = options.progress;
  so.logging_type = options.progress ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  so.num_threads = 1;
  static const bool quiet_glog = []
  {
    // Ceres logs through glog: keep its stderr lines out of the report
    // (the termination message is in the report)
    if (!google::IsGoogleLoggingInitialized())
      google::InitGoogleLogging("muscle-fit");
    FLAGS_minloglevel = google::GLOG_FATAL;
    return true;
  }();
  (void)quiet_glog;
  return so;
}

/// Moves x to the solution; the solver's summary goes into `result`.
void solve(const Problem& problem, std::vector<double>& x, const FitOptions& options,
           FitResult& result)
{
  const std::size_t n = x.size();
  if (n == 0)
  {
    result.converged = true;
    result.termination = "nothing to fit (no free parameters)";
    return;
  }
  ceres::Problem cp;
  cp.AddResidualBlock(new Cost(problem), nullptr, x.data());
  for (std::size_t j = 0; j < n; ++j)
  {
    if (std::isfinite(problem.lower[j]))
      cp.SetParameterLowerBound(x.data(), static_cast<int>(j), problem.lower[j]);
    if (std::isfinite(problem.upper[j]))
      cp.SetParameterUpperBound(x.data(), static_cast<int>(j), problem.upper[j]);
  }
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options(options), &cp, &summary);
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;
  result.termination = summary.message;
  result.initial_cost = summary.initial_cost;
}

/// The fitted parameters at x, their residuals and cost.
void evaluate_at(const Problem& problem, const std::vector<double>& x, FitResult& result)
{
  result.fitted = problem.parameters(x.data());
  result.residuals.resize(problem.rows());
  problem.residuals(x.data(), result.residuals.data());
  result.cost = 0;
  for (double r : result.residuals)
    result.cost += 0.5 * r * r;
}

/// The Jacobian in the parameters' own units, the parameters that end on a
/// bound, and the values and magnitudes the identifiability analysis takes.
void differentiate_at(const Problem& problem, const std::vector<double>& x, FitResult& result,
                      std::vector<double>& values, std::vector<double>& reference)
{
  const std::size_t n = problem.cols(), m = problem.rows();
  std::vector<double> Jx(m * n);
  if (n > 0 and !problem.jacobian(x.data(), problem.lower, problem.upper, Jx.data()))
    throw SolveError("the Jacobian at the solution could not be evaluated");
  result.jacobian.resize(m * n);
  for (std::size_t j = 0; j < n; ++j)
  {
    for (std::size_t i = 0; i < m; ++i)
      result.jacobian[i * n + j] = Jx[i * n + j] / problem.scale(j);
    // relative changes; a parameter at (or near) zero is measured in its start scale
    const double v = result.fitted[result.free[j]];
    values.push_back(v);
    reference.push_back(std::abs(v) > 1e-6 * problem.scale(j) ? v : problem.scale(j));
    const double tol = 1e-9 * std::max(1.0, std::abs(x[j]));
    if (x[j] - problem.lower[j] <= tol or problem.upper[j] - x[j] <= tol)
      result.at_bound.push_back(result.free[j]);
  }
}

// Parameters without influence are returned at their start values: the
// solver may have moved them along a numerically-zero column (Ceres scales
// columns to unit norm), which changes nothing but would look like a result.
void reset_without_influence(const Problem& problem, std::vector<double>& x, FitResult& result)
{
  if (result.identifiability.no_influence.empty())
    return;
  for (const std::string& name : result.identifiability.no_influence)
  {
    const std::size_t j
        = std::find(result.free.begin(), result.free.end(), name) - result.free.begin();
    x[j] = result.start[name] / problem.scale(j);
  }
  evaluate_at(problem, x, result);
}
} // namespace

FitResult fit_parameters(const ParameterSet& start, const std::vector<DataPoint>& data,
                         const FitOptions& options)
{
  if (data.empty())
    throw InputError("no data to fit");
  FitResult result;
  result.start = start;
  result.free = options.free ? *options.free : default_free_parameters(start.model());
  detail::check_free_and_bounds(start, result.free, options.bounds);
  start.validate();
  result.start = detail::start_values(start, result.free);

  const std::map<CurveKey, double> curve_weight = curve_weights(data, options);
  std::vector<double> sqrt_w;
  for (const DataPoint& d : data)
    sqrt_w.push_back(std::sqrt(curve_weight.at({d.load_case, d.state})));
  Problem problem(result.start, data, result.free, sqrt_w);
  std::vector<double> x = detail::scaled_start(problem, start, result.free, options.bounds);
  std::vector<double> r0(problem.rows());
  if (!problem.residuals(x.data(), r0.data()))
  {
    // say why: rerun the evaluation and let the error through
    start.validate();
    (void)model_stresses(start, data);
    throw InputError("the model response is not finite at the start values");
  }

  solve(problem, x, options, result);
  evaluate_at(problem, x, result);
  if (x.empty())
    result.initial_cost = result.cost;
  std::vector<double> values, reference;
  differentiate_at(problem, x, result, values, reference);
  result.identifiability
      = analyse_identifiability(result.jacobian, problem.rows(), result.free, values, reference,
                                result.residuals, detail::row_scales(data, sqrt_w));
  reset_without_influence(problem, x, result);
  result.model = model_stresses(result.fitted, data);
  result.errors = detail::curve_errors(data, result.model, curve_weight);
  return result;
}

} // namespace muscle::fit
