#include "fit/fit.h"

#include <common/errors.h>

#include <Eigen/Dense>
#include <algorithm>
#include <ceres/ceres.h>
#include <glog/logging.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>

namespace muscle::fit
{
namespace
{
constexpr double inf = std::numeric_limits<double>::infinity();

std::string fmt(const char* format, double v)
{
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, v);
  return buffer;
}

const ParameterSpec& spec_of(const Model& model, const std::string& name)
{
  for (const ParameterSpec& s : parameter_specs(model))
    if (s.name == name)
      return s;
  (void)ParameterSet{model}[name]; // throws with did-you-mean
  throw InputError("unknown parameter " + name);
}

/// The fit problem in scaled variables x_j = p_j / scale_j.
class Problem
{
public:
  Problem(const ParameterSet& start, const std::vector<DataPoint>& data,
          std::vector<std::string> free, std::vector<double> sqrt_weights)
      : _base(start), _data(data), _free(std::move(free)),
        _sqrt_weights(std::move(sqrt_weights))
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

  std::size_t rows() const { return _data.size(); }
  std::size_t cols() const { return _free.size(); }
  double scale(std::size_t j) const { return _scale[j]; }

  ParameterSet parameters(const double* x) const
  {
    ParameterSet p = _base;
    for (std::size_t j = 0; j < _free.size(); ++j)
      p.set(_free[j], x[j] * _scale[j]);
    return p;
  }

  /// False if the parameters are not admissible or P_exact fails.
  bool residuals(const double* x, double* r) const
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

  /// Central differences (one-sided at a bound) in the scaled variables.
  bool jacobian(const double* x, const std::vector<double>& lower,
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

  std::vector<double> lower, upper; // scaled bounds

private:
  ParameterSet _base;
  const std::vector<DataPoint>& _data;
  std::vector<std::string> _free;
  std::vector<double> _sqrt_weights;
  std::vector<double> _scale;
};

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

double weight_of(const std::map<std::string, double>& weights, const CurveKey& k)
{
  const std::string c = muscle::to_string(k.load_case);
  if (auto it = weights.find(c + ":" + muscle::to_string(k.state)); it != weights.end())
    return it->second;
  if (auto it = weights.find(c); it != weights.end())
    return it->second;
  return 1;
}

std::string name_list(const std::vector<std::pair<std::string, double>>& c)
{
  std::string out;
  for (const auto& [name, v] : c)
  {
    if (!out.empty())
      out += ' ';
    out += fmt("%+.2f ", v);
    out += name;
  }
  return out;
}
} // namespace

std::vector<std::string> default_free_parameters(const Model& model)
{
  const auto& names = model.law().fit_parameters;
  return {names.begin(), names.end()};
}

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

std::vector<std::string> Identifiability::flagged() const
{
  std::vector<std::string> out = no_influence;
  for (const std::string& name : uncertain)
    out.push_back(name);
  for (const Combination& c : weak)
    for (const auto& [name, v] : c.components)
      if (std::find(out.begin(), out.end(), name) == out.end())
        out.push_back(name);
  return out;
}

Identifiability analyse_identifiability(const std::vector<double>& jacobian, std::size_t m,
                                        const std::vector<std::string>& names,
                                        const std::vector<double>& values,
                                        const std::vector<double>& reference,
                                        const std::vector<double>& residuals,
                                        const std::vector<double>& row_scale)
{
  const std::size_t n = names.size();
  Identifiability id;
  id.names = names;
  id.relative_std_error.assign(n, inf);
  // J: weighted residuals per relative parameter change; N: the same rows
  // scaled to "relative change of the curve"
  Eigen::MatrixXd J(m, n), N(m, n);
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = 0; j < n; ++j)
    {
      J(i, j) = jacobian[i * n + j] * std::abs(reference[j]);
      N(i, j) = J(i, j) * row_scale[i];
    }
  std::vector<std::size_t> seen; // columns with influence
  for (std::size_t j = 0; j < n; ++j)
  {
    if (!(N.col(j).norm() > Identifiability::no_influence_limit))
      id.no_influence.push_back(names[j]);
    else
      seen.push_back(j);
  }
  if (seen.empty())
    return id;
  Eigen::MatrixXd Ns(m, seen.size()), Js(m, seen.size());
  for (std::size_t k = 0; k < seen.size(); ++k)
  {
    Ns.col(k) = N.col(seen[k]);
    Js.col(k) = J.col(seen[k]);
  }
  const std::size_t ns = std::min<std::size_t>(m, seen.size());
  {
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(Ns, Eigen::ComputeThinV);
    const Eigen::VectorXd& sv = svd.singularValues();
    const Eigen::MatrixXd& V = svd.matrixV();
    for (int k = 0; k < sv.size(); ++k)
      id.singular_values.push_back(sv(k));
    for (std::size_t k = 0; k < seen.size(); ++k)
    {
      // m < n leaves directions without a singular value: undetermined too
      const double value = k < ns ? sv(k) : 0.0;
      if (value >= Identifiability::poorly_determined_limit)
        continue;
      Identifiability::Combination c{value, value >= Identifiability::undetermined_limit, {}};
      for (std::size_t q = 0; q < seen.size(); ++q)
        if (std::abs(V(q, k)) >= 0.1)
          c.components.emplace_back(names[seen[q]], V(q, k));
      std::sort(c.components.begin(), c.components.end(),
                [](auto& a, auto& b) { return std::abs(a.second) > std::abs(b.second); });
      id.weak.push_back(c);
    }
  }
  // standard errors from the weighted problem, on its determined subspace
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Js, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const Eigen::MatrixXd& V = svd.matrixV();
  std::size_t rank = 0;
  for (std::size_t k = 0; k < ns; ++k)
    if (sv(k) > 1e-9 * sv(0))
      ++rank;
  if (m > rank)
  {
    double ss = 0;
    for (double r : residuals)
      ss += r * r;
    const double s2 = ss / static_cast<double>(m - rank);
    for (std::size_t q = 0; q < seen.size(); ++q)
    {
      double var = 0;
      bool in_null = false;
      for (std::size_t k = 0; k < seen.size(); ++k)
      {
        if (k < rank)
          var += V(q, k) * V(q, k) / (sv(k) * sv(k));
        else if (std::abs(V(q, k)) >= 0.1)
          in_null = true;
      }
      id.relative_std_error[seen[q]] = in_null ? inf : std::sqrt(s2 * var);
    }
  }
  id.std_error.resize(n);
  for (std::size_t j = 0; j < n; ++j)
  {
    id.std_error[j] = id.relative_std_error[j] * std::abs(reference[j]);
    const bool flagged
        = std::find(id.no_influence.begin(), id.no_influence.end(), names[j])
          != id.no_influence.end();
    if (!flagged and std::isfinite(id.relative_std_error[j])
        and id.std_error[j] > std::abs(values[j]))
      id.uncertain.push_back(names[j]);
  }
  return id;
}

std::string Identifiability::text() const
{
  std::ostringstream out;
  out << "identifiability (Jacobian at the solution, columns scaled by |p|):\n";
  if (!singular_values.empty())
  {
    out << "  singular values (relative change of the curves per relative change of the "
           "parameters):\n   ";
    for (double s : singular_values)
      out << " " << fmt("%.2e", s);
    out << "\n";
  }
  if (all_determined())
    out << "  all free parameters are determined by the data\n";
  for (const std::string& name : no_influence)
    out << "  WARNING: " << name
        << " is not determined: it has no influence on these data (value kept at its "
           "start value)\n";
  for (std::size_t j = 0; j < names.size(); ++j)
    if (std::find(uncertain.begin(), uncertain.end(), names[j]) != uncertain.end())
      out << "  WARNING: " << names[j] << " is not determined by the scatter of these data: "
          << "its standard error " << fmt("%.3g", std_error[j])
          << " exceeds its value\n";
  for (const Combination& c : weak)
  {
    if (c.components.size() == 1)
      out << "  WARNING: " << c.components.front().first << " is "
          << (c.determined ? "poorly determined" : "not determined") << " by these data"
          << " (singular value " << fmt("%.1e", c.singular_value) << ")\n";
    else
      out << "  WARNING: the combination " << name_list(c.components)
          << " (relative changes) is "
          << (c.determined ? "poorly determined" : "not determined")
          << " (singular value " << fmt("%.1e", c.singular_value)
          << "): the data fix only the other combinations of these parameters\n";
  }
  if (!all_determined())
    out << "  (fix the flagged parameters with --fix or add load cases that depend on them)\n";
  return out.str();
}

FitResult fit_parameters(const ParameterSet& start, const std::vector<DataPoint>& data,
                         const FitOptions& options)
{
  if (data.empty())
    throw InputError("no data to fit");
  const Model model = start.model();
  FitResult result;
  result.start = start;
  result.free = options.free ? *options.free : default_free_parameters(model);
  for (std::size_t j = 0; j < result.free.size(); ++j)
  {
    (void)start[result.free[j]]; // unknown name: InputError with suggestion
    for (std::size_t k = 0; k < j; ++k)
      if (result.free[k] == result.free[j])
        throw InputError("parameter " + result.free[j] + " is listed twice as free");
  }
  for (const auto& [name, b] : options.bounds)
  {
    (void)start[name];
    if (std::find(result.free.begin(), result.free.end(), name) == result.free.end())
      throw InputError("bounds given for " + name + ", which is not free; free: "
                       + join(result.free));
    if (!(b.lower < b.upper))
      throw InputError("bounds of " + name + ": lower " + fmt("%g", b.lower)
                       + " must be below upper " + fmt("%g", b.upper));
  }
  start.validate();
  if (uses_twitch_train(model) and start.explicitly_set("P_opt")
      and std::find(result.free.begin(), result.free.end(), "N_a") != result.free.end())
  {
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
    result.start = derived;
  }

  // curves and weights
  std::set<CurveKey> curves;
  for (const DataPoint& d : data)
    curves.insert({d.load_case, d.state});
  for (const auto& [key, w] : options.weights)
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
  std::vector<double> sqrt_w;
  for (const DataPoint& d : data)
    sqrt_w.push_back(std::sqrt(curve_weight[{d.load_case, d.state}]));

  Problem problem(result.start, data, result.free, sqrt_w);
  const std::size_t n = problem.cols(), m = problem.rows();
  std::vector<double> x(n);
  problem.lower.resize(n);
  problem.upper.resize(n);
  for (std::size_t j = 0; j < n; ++j)
  {
    const std::string& name = result.free[j];
    const double s = problem.scale(j);
    Bounds b = admissible(spec_of(model, name), s);
    if (auto it = options.bounds.find(name); it != options.bounds.end())
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

  std::vector<double> r0(m);
  if (!problem.residuals(x.data(), r0.data()))
  {
    // say why: rerun the evaluation and let the error through
    start.validate();
    (void)model_stresses(start, data);
    throw InputError("the model response is not finite at the start values");
  }

  if (n > 0)
  {
    ceres::Problem cp;
    cp.AddResidualBlock(new Cost(problem), nullptr, x.data());
    for (std::size_t j = 0; j < n; ++j)
    {
      if (std::isfinite(problem.lower[j]))
        cp.SetParameterLowerBound(x.data(), static_cast<int>(j), problem.lower[j]);
      if (std::isfinite(problem.upper[j]))
        cp.SetParameterUpperBound(x.data(), static_cast<int>(j), problem.upper[j]);
    }
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
    ceres::Solver::Summary summary;
    ceres::Solve(so, &cp, &summary);
    result.converged = summary.termination_type == ceres::CONVERGENCE;
    result.iterations = static_cast<int>(summary.iterations.size()) - 1;
    result.termination = summary.message;
    result.initial_cost = summary.initial_cost;
  }
  else
  {
    result.converged = true;
    result.termination = "nothing to fit (no free parameters)";
  }

  result.fitted = problem.parameters(x.data());
  result.residuals.resize(m);
  problem.residuals(x.data(), result.residuals.data());
  result.cost = 0;
  for (double r : result.residuals)
    result.cost += 0.5 * r * r;
  if (n == 0)
    result.initial_cost = result.cost;
  std::vector<double> Jx(m * n);
  if (n > 0 and !problem.jacobian(x.data(), problem.lower, problem.upper, Jx.data()))
    throw SolveError("the Jacobian at the solution could not be evaluated");
  result.jacobian.resize(m * n);
  std::vector<double> values, reference;
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
  // rows scaled so that a curve's block measures the RMS change of that curve
  // relative to its own RMS magnitude
  std::map<CurveKey, std::pair<double, std::size_t>> magnitude; // sum stress^2, count
  for (const DataPoint& d : data)
  {
    auto& [ss, count] = magnitude[{d.load_case, d.state}];
    ss += d.stress * d.stress;
    ++count;
  }
  double largest_rms = 0;
  for (const auto& [k, v] : magnitude)
    largest_rms = std::max(largest_rms, std::sqrt(v.first / v.second));
  std::vector<double> row_scale(m, 0.0);
  for (std::size_t i = 0; i < m; ++i)
  {
    const auto& [ss, count] = magnitude[{data[i].load_case, data[i].state}];
    const double rms = std::max(std::sqrt(ss / count), 1e-3 * largest_rms);
    if (sqrt_w[i] > 0)
      row_scale[i] = 1 / (sqrt_w[i] * rms * std::sqrt(double(count)));
  }
  result.identifiability = analyse_identifiability(result.jacobian, m, result.free, values,
                                                   reference, result.residuals, row_scale);

  // Parameters without influence are returned at their start values: the
  // solver may have moved them along a numerically-zero column (Ceres scales
  // columns to unit norm), which changes nothing but would look like a result.
  if (!result.identifiability.no_influence.empty())
  {
    for (const std::string& name : result.identifiability.no_influence)
    {
      const std::size_t j
          = std::find(result.free.begin(), result.free.end(), name) - result.free.begin();
      x[j] = result.start[name] / problem.scale(j);
    }
    result.fitted = problem.parameters(x.data());
    problem.residuals(x.data(), result.residuals.data());
    result.cost = 0;
    for (double r : result.residuals)
      result.cost += 0.5 * r * r;
  }
  result.model = model_stresses(result.fitted, data);
  for (const CurveKey& k : curves)
  {
    std::vector<double> xm, xs;
    for (std::size_t i = 0; i < m; ++i)
      if (CurveKey{data[i].load_case, data[i].state} == k)
      {
        xm.push_back(result.model[i]);
        xs.push_back(data[i].stress);
      }
    result.errors.push_back({k, xm.size(), curve_weight[k], error_measures(xm, xs)});
  }
  return result;
}

std::string report_text(const FitResult& r)
{
  std::ostringstream out;
  const ParameterSet& p = r.fitted;
  out << "model " << to_string(p.model()) << ": " << r.residuals.size() << " data points, "
      << r.free.size() << " free parameters\n";
  out << "solver (Ceres, trust region LM, bounds): " << (r.converged ? "converged" : "NOT converged")
      << " after " << r.iterations << " iterations: " << r.termination << "\n";
  out << "cost 1/2 sum w r^2: " << fmt("%.6g", r.initial_cost) << " -> " << fmt("%.6g", r.cost)
      << "\n\n";
  char line[256];
  std::snprintf(line, sizeof line, "%-12s %14s %14s %10s  %s\n", "parameter", "start", "fitted",
                "std.error", "");
  out << line;
  for (const std::string& name : p.names())
  {
    const auto it = std::find(r.free.begin(), r.free.end(), name);
    if (it == r.free.end())
      continue;
    const std::size_t j = it - r.free.begin();
    const double se = r.identifiability.std_error.empty() ? inf
                                                          : r.identifiability.std_error[j];
    const auto flagged = r.identifiability.flagged();
    std::string note;
    if (std::find(flagged.begin(), flagged.end(), name) != flagged.end())
      note += " not (well) determined";
    if (std::find(r.at_bound.begin(), r.at_bound.end(), name) != r.at_bound.end())
      note += " at a bound";
    std::snprintf(line, sizeof line, "%-12s %14.7g %14.7g %10s %s\n", name.c_str(),
                  r.start[name], p[name], std::isfinite(se) ? fmt("%.3g", se).c_str() : "-",
                  note.c_str());
    out << line;
  }
  std::vector<std::string> fixed;
  for (const std::string& name : p.names())
    if (std::find(r.free.begin(), r.free.end(), name) == r.free.end())
    {
      if (name == "P_opt" and uses_twitch_train(p.model()) and !p.explicitly_set("P_opt"))
        out << "P_opt = " << fmt("%.7g", p[name])
            << " follows N_a and the twitch parameters (tetanic level)\n";
      else
        fixed.push_back(name);
    }
  out << "fixed: " << join(fixed) << "\n\n";
  std::snprintf(line, sizeof line, "%-16s %6s %8s %8s %8s %8s\n", "curve", "points", "weight",
                "eps_inf", "eps_1", "eps_2");
  out << "errors of P_exact against the data (paper appendix \"Error measures\"):\n" << line;
  for (const CurveErrors& e : r.errors)
  {
    std::snprintf(line, sizeof line, "%-16s %6zu %8.3g %8.4f %8.4f %8.4f\n",
                  to_string(e.key).c_str(), e.points, e.weight, e.errors.eps_inf,
                  e.errors.eps_1, e.errors.eps_2);
    out << line;
  }
  out << "\n" << r.identifiability.text();
  return out.str();
}

std::string report_json(const FitResult& r)
{
  nlohmann::json j;
  j["model"] = to_string(r.fitted.model());
  j["converged"] = r.converged;
  j["iterations"] = r.iterations;
  j["termination"] = r.termination;
  j["cost"] = r.cost;
  j["initial_cost"] = r.initial_cost;
  j["free"] = r.free;
  j["at_bound"] = r.at_bound;
  for (const std::string& name : r.fitted.names())
  {
    j["parameters"][name] = r.fitted[name];
    j["start"][name] = r.start[name];
  }
  for (std::size_t k = 0; k < r.free.size(); ++k)
  {
    const double se = r.identifiability.std_error[k];
    j["std_error"][r.free[k]] = std::isfinite(se) ? nlohmann::json(se) : nullptr;
  }
  for (const CurveErrors& e : r.errors)
    j["errors"].push_back({{"case", to_string(e.key.load_case)},
                           {"state", to_string(e.key.state)},
                           {"points", e.points},
                           {"weight", e.weight},
                           {"eps_inf", e.errors.eps_inf},
                           {"eps_1", e.errors.eps_1},
                           {"eps_2", e.errors.eps_2}});
  const Identifiability& id = r.identifiability;
  j["identifiability"]["all_determined"] = id.all_determined();
  j["identifiability"]["singular_values"] = id.singular_values;
  j["identifiability"]["no_influence"] = id.no_influence;
  j["identifiability"]["uncertain"] = id.uncertain;
  j["identifiability"]["flagged"] = id.flagged();
  j["identifiability"]["weak_combinations"] = nlohmann::json::array();
  for (const auto& c : id.weak)
  {
    nlohmann::json cj;
    cj["singular_value"] = c.singular_value;
    cj["determined"] = c.determined;
    for (const auto& [name, v] : c.components)
      cj["components"][name] = v;
    j["identifiability"]["weak_combinations"].push_back(cj);
  }
  return j.dump(2) + "\n";
}

std::vector<DataPoint> synthesize(const ParameterSet& p, const std::vector<CurveKey>& curves,
                                  const std::vector<double>& stretches,
                                  const std::vector<double>& shears, Kinematics kinematics,
                                  double noise, unsigned seed)
{
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0, 1);
  std::vector<DataPoint> out;
  for (const CurveKey& k : curves)
  {
    const std::vector<double>& controls = k.load_case == LoadCase::SAF ? shears : stretches;
    std::vector<double> stress;
    if (kinematics == Kinematics::paper and k.load_case == LoadCase::UTCTF)
    {
      for (double s : controls)
      {
        const auto v = paper_response(p, k.load_case, k.state, s);
        if (!v)
          throw InputError("the paper's UTCTF kinematics have a closed form for the "
                           "passive state only");
        stress.push_back(*v);
      }
    }
    else
      stress = model_curve(p, k, controls);
    double peak = 0;
    for (double v : stress)
      peak = std::max(peak, std::abs(v));
    for (std::size_t i = 0; i < controls.size(); ++i)
      out.push_back({k.load_case, k.state, controls[i],
                     stress[i] + noise * peak * normal(rng), "", 0});
  }
  return out;
}

} // namespace muscle::fit
