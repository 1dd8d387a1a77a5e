#pragma once

#include "fem/newton/nonlinear_solver.h"

#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace muscle
{
class GeneralizedAlpha;

struct TimeSteppingOptions
{
  double t_start = 0;
  double t_end = 0.15;
  double dt = 0.005;          ///< output step; sub-steps are taken on failure
  double cutback_factor = 0.5; ///< step multiplier after a failed Newton solve
  int max_cutbacks = 8;       ///< the smallest step is dt * factor^max_cutbacks
  double growth_factor = 1.5; ///< step multiplier after two successes (up to dt)
  /// Resuming: the sub-step and success count the interrupted run had reached
  /// (0: start with dt), so the resumed run takes the very same steps.
  double first_substep = 0;
  int first_successes = 0;

  /// The output steps from t_start to t_end: a tail below a thousandth of dt
  /// joins the last step rather than make one of its own.
  int steps() const
  {
    return static_cast<int>(std::ceil((t_end - t_start) / dt - 1e-3));
  }
};

/// One converged output time.
struct StepRecord
{
  double t = 0;
  int newton_iterations = 0;  ///< summed over the sub-steps to reach t
  int linear_iterations = 0;
  int substeps = 0;
  int cutbacks = 0;
  double residual = 0;        ///< final residual norm of the last sub-step
  double next_substep = 0;    ///< sub-step the stepper will try next
  int successes = 0;          ///< consecutive successes (step growth)
};

/// Why a run stopped early.
struct StepFailure
{
  double t_converged = 0;  ///< last converged time (state kept there)
  double t_attempted = 0;  ///< the time the smallest step tried to reach
  int step = 0;            ///< output step index being attempted
  std::string reason;      ///< SNES reason, non-finite residual, kernel, ...
  std::string where;       ///< worst element: inverted or no activation root
  std::string advice;      ///< what to try
  int newton_iterations = 0; ///< spent on the failed output step, all attempts
  int cutbacks = 0;          ///< attempts that failed on it
  /// the line search's step length of each Newton step of the last attempt
  std::vector<double> step_lengths;

  /// The fields above for a run's summary.json.
  nlohmann::json to_json() const;

  /// The stop message: what failed at which step, where, where the last
  /// converged state was written (`out`), and what to try.
  std::string message(int step_number, const std::string& out) const;
};

/// Time stepping: for each output time solve the equilibrium (quasi-static) or
/// the equation of motion (with set_dynamics) with `solver`, after calling
/// `set_time(t)` (activation, boundary values).  A failed Newton solve restores
/// the last converged displacement and cuts the step back; steps grow again
/// after successes.  `on_output` runs after every converged output time;
/// returns false from it to stop.
class QuasiStaticStepper
{
public:
  QuasiStaticStepper(MuscleProblem& problem, NonlinearSolver& solver,
                     std::function<void(double)> set_time, TimeSteppingOptions options);

  /// Structural dynamics: the integrator is told each sub-step's length before
  /// its solve and each converged sub-step (its inertia term is the solver's).
  void set_dynamics(GeneralizedAlpha* dynamics) { _dynamics = dynamics; }

  /// Run to t_end; the returned failure is empty if it got there.
  std::optional<StepFailure>
  run(const std::function<bool(const StepRecord&)>& on_output);

private:
  StepFailure diagnose(double t_converged, double t_attempted, int step,
                       const NewtonReport& report) const;

  MuscleProblem& _problem;
  NonlinearSolver& _solver;
  std::function<void(double)> _set_time;
  TimeSteppingOptions _options;
  GeneralizedAlpha* _dynamics = nullptr;
};

} // namespace muscle
