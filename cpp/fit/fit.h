#pragma once

// Material parameter identification: bounded nonlinear least squares (Ceres,
// trust region) of the exact homogeneous load-case responses P_exact against
// stress-stretch data, with the paper's error measures and an identifiability
// analysis of the Jacobian at the solution.
#include "fit/data.h"

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace muscle::fit
{

/// The parameters fitted unless the user says otherwise: those the paper fits
/// (Table fitting_all).  BLE: G1 G2 P1 P2 lambda_opt alpha_a mu; WKM/GIANT:
/// alpha beta gamma omega_0 lambda_opt lambda_min N_a (P_opt follows N_a);
/// COMBI: alpha beta gamma omega_0 lambda_opt lambda_min P_opt.
std::vector<std::string> default_free_parameters(const Model& model);

struct Bounds
{
  double lower;
  double upper;
};

struct FitOptions
{
  /// Parameters to fit; unset: default_free_parameters (an empty list fits
  /// nothing and only evaluates the errors).
  std::optional<std::vector<std::string>> free;
  std::map<std::string, Bounds> bounds; ///< intersected with the admissible range
  /// Weight of the squared residuals of a curve; key "CASE" or "CASE:state"
  /// (the latter wins); default 1.
  std::map<std::string, double> weights;
  /// Divide each curve's residuals by its largest |stress| (weights 1/peak^2 on
  /// top of `weights`): relative misfit, right for noise proportional to the
  /// curve size.  Default off: absolute kPa, as the paper minimises.
  bool scale_curves = false;
  int max_iterations = 200;
  bool progress = false; ///< Ceres' per-iteration lines on stdout
};

/// Relative errors of the paper's appendix "Error measures", x = model,
/// x* = data: eps_inf = max|x - x*| / max|x*|, eps_1 = sum|x - x*| / sum|x*|,
/// and eps_2 = ||x - x*||_2 / ||x*||_2 (the L2 analogue the paper's text names).
struct ErrorMeasures
{
  double eps_inf;
  double eps_1;
  double eps_2;
};
ErrorMeasures error_measures(const std::vector<double>& model,
                             const std::vector<double>& data);

struct CurveErrors
{
  CurveKey key;
  std::size_t points;
  double weight;
  ErrorMeasures errors;
};

/// What the data determine.  From the Jacobian at the solution with respect
/// to relative parameter changes (column j scaled by |p_j|) and with the rows
/// of each curve scaled by 1/(RMS of the curve's data x sqrt(points)), so that
/// J v measures how much each curve changes relative to its own size when the
/// parameters change by the relative amounts v:
/// * a parameter whose column is (numerically) zero has no influence on the
///   data (norm < no_influence_limit);
/// * a singular value s < undetermined_limit is a combination the data cannot
///   determine (a null direction, e.g. a product of parameters);
/// * s < poorly_determined_limit: changing the parameters by 100 % along that
///   direction changes the curves by less than 0.1 % -- below any measurement
///   accuracy, so poorly determined.
struct Identifiability
{
  struct Combination
  {
    double singular_value; ///< s
    bool determined;  ///< false: s < undetermined_limit
    std::vector<std::pair<std::string, double>> components; ///< |v_j| >= 0.1
  };
  static constexpr double no_influence_limit = 1e-7;
  static constexpr double undetermined_limit = 1e-6;
  static constexpr double poorly_determined_limit = 1e-3;

  std::vector<std::string> names;
  std::vector<double> singular_values;   ///< of the scaled J, descending
  std::vector<std::string> no_influence; ///< parameters the data do not see
  std::vector<Combination> weak;         ///< undetermined or poorly determined
  /// Standard error of each parameter relative to `reference`, sqrt(s^2 (J^T J)^+_jj) with
  /// s^2 = sum r^2 / (m - rank) (infinite for parameters without influence
  /// or in an undetermined combination; meaningful if the residuals are noise).
  std::vector<double> relative_std_error;
  std::vector<double> std_error; ///< absolute: relative x |p| (start value if p ~ 0)
  /// Free parameters whose standard error exceeds their value: the scatter of
  /// these data does not determine them (only flagged if s^2 > 0 is meaningful,
  /// i.e. the data are not reproduced exactly).
  std::vector<std::string> uncertain;

  bool all_determined() const
  {
    return no_influence.empty() and weak.empty() and uncertain.empty();
  }
  std::vector<std::string> flagged() const; ///< every parameter named in a warning
  std::string text() const;                 ///< the report section
};

/// `jacobian`: m x n row-major, d(weighted residual)/d(parameter);
/// `values`: the fitted values; `reference`: the magnitudes relative changes are
/// measured in (|value|, or the start value for parameters at zero);
/// `row_scale`: factor of each row for the structural analysis (see above).
Identifiability analyse_identifiability(const std::vector<double>& jacobian,
                                        std::size_t m,
                                        const std::vector<std::string>& names,
                                        const std::vector<double>& values,
                                        const std::vector<double>& reference,
                                        const std::vector<double>& residuals,
                                        const std::vector<double>& row_scale);

struct FitResult
{
  /// before a fit: the law declared DEFAULT_FOR "fit" (BLE)
  ParameterSet start{default_model("fit")};
  ParameterSet fitted{default_model("fit")};
  std::vector<std::string> free;
  std::vector<std::string> at_bound; ///< free parameters that end on a bound
  std::vector<double> residuals;     ///< weighted, at the solution
  std::vector<double> jacobian;      ///< m x n, d residual / d parameter
  std::vector<double> model;         ///< P_exact at the data points
  double cost = 0;                   ///< 1/2 sum residual^2
  double initial_cost = 0;
  bool converged = false;
  int iterations = 0;
  std::string termination; ///< Ceres' message
  std::vector<CurveErrors> errors;
  Identifiability identifiability;
};

/// Fit the free parameters of `start` (its values are the start values) to the
/// data.  Residual of a point: sqrt(weight) (P_exact(stretch) - stress), the
/// weight of its curve (CurveErrors::weight) including scale_curves.
/// InputError for unknown names, bounds that exclude the start value, weights
/// of curves absent from the data, or a start at which P_exact fails.
FitResult fit_parameters(const ParameterSet& start, const std::vector<DataPoint>& data,
                         const FitOptions& options);

/// P_exact [kPa] at every data point.
std::vector<double> model_stresses(const ParameterSet& p,
                                   const std::vector<DataPoint>& data);

/// P_exact of one curve at the controls.
std::vector<double> model_curve(const ParameterSet& p, const CurveKey& key,
                                const std::vector<double>& controls);

/// Human-readable report: parameters (start, fitted, bounds, rel. std. error),
/// solver summary, per-curve eps_inf/eps_1/eps_2, identifiability.
std::string report_text(const FitResult& result);

/// JSON for machines (same content as the report).
std::string report_json(const FitResult& result);

/// How synthetic data are generated: the exact response, or for UTCTF the
/// paper's kinematics F = diag(l, l^-1/2, l^-1/2) (its closed form, passive
/// only; ERRATA.md item 8), the exact response for the other cases.
enum class Kinematics
{
  exact,
  paper
};

/// Data from known parameters: every case x state at the controls (SAF at
/// `shears`), plus Gaussian noise of standard deviation noise x max|P| of each
/// curve (seeded, reproducible).
std::vector<DataPoint> synthesize(const ParameterSet& p,
                                  const std::vector<CurveKey>& curves,
                                  const std::vector<double>& stretches,
                                  const std::vector<double>& shears,
                                  Kinematics kinematics, double noise,
                                  unsigned seed);


} // namespace muscle::fit
