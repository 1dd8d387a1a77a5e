// What a Newton solve did, and in words why it failed: PETSc's reason, a
// stagnation, a failed linear solve, the terms' own diagnosis.
#include "fem/newton/nonlinear_solver.h"

#include "fem/linear/linear_failure.h"
#include "fem/newton/formulation.h"

#include <cstdio>

using namespace dolfinx;

namespace muscle
{

NewtonReport NonlinearSolver::outcome(PetscErrorCode error, long inner_iterations_before) const
{
  NewtonReport report;
  SNESConvergedReason reason;
  SNESGetConvergedReason(_snes, &reason);
  if (error and reason > 0)
    reason = SNES_DIVERGED_FUNCTION_DOMAIN; // never report an errored solve as converged
  // the cp line search declares FNORM_ABS itself, without the convergence test,
  // where dot(F, dx) vanishes: rightly at a residual of round-off size, wrongly
  // for a zero direction, which only a failed linear solve returns (whatever its
  // Krylov method reported)
  const bool untested = reason > 0 and _test_verdict <= 0 and zero_update();
  if (untested)
    reason = SNES_DIVERGED_LINEAR_SOLVE;
  // nor with theta still away from J0(u), which the test refused (solve() finishes
  // such a stop of cp with full steps, which never stop this way)
  const bool theta_unmet = reason > 0 and stopped_short_of_constraint();
  if (theta_unmet)
    reason = SNES_DIVERGED_LINE_SEARCH;
  report.converged = reason > 0 and !error;
  if (_stagnated)
    report.reason = "STAGNATED (residual down by less than "
                    + std::to_string(_options.stagnation_reduction) + " in "
                    + std::to_string(_options.stagnation_window) + " iterations)";
  else if (_crept)
  {
    char text[200];
    std::snprintf(text, sizeof text,
                  "LINE SEARCH CREEPING (%s took less than %g of the Newton step in %d "
                  "successive iterations)",
                  line_search().c_str(), _options.creep_step, _options.creep_window);
    report.reason = text;
  }
  else
    report.reason = SNESConvergedReasons[reason];
  if (error)
  {
    // in the displacement Newton the error escapes SNES from its KSP
    report.reason = "DIVERGED_LINEAR_SOLVE";
    // (the trust region's check stops the solve by an error: the KSP says why)
    report.linear_failure = describe_linear_failure(
        linear_solver(), _trust_region_linear_failure ? _formulation->linear_error() : error);
  }
  else if (untested)
    report.linear_failure = "it returned a zero direction, and the line search stopped "
                            "at its initial point";
  else if (theta_unmet)
  {
    char text[200];
    std::snprintf(text, sizeof text,
                  " (the solve stopped without the convergence test, the line search's own "
                  "stop, with theta away from J0(u): |J0(u) - theta| = %.1e > %.1e)",
                  _formulation->constraint_violation(), _options.fbar_constraint_tolerance);
    report.reason += text;
  }
  else if (reason == SNES_DIVERGED_LINEAR_SOLVE)
    report.linear_failure = describe_linear_failure(linear_solver(), _formulation->linear_error());
  const std::string& inner_failure = _formulation->linear_solver().inner_failure();
  if (!report.linear_failure.empty() and !inner_failure.empty())
    report.linear_failure += "; inner solve " + inner_failure;
  if (!report.linear_failure.empty())
    report.reason += " (" + report.linear_failure + ")";
  if (!report.converged)
    for (const auto& t : _system.terms())
      if (const std::string d = t->diagnosis(); !d.empty())
        report.reason += "; " + d;
  PetscInt its, lits;
  SNESGetIterationNumber(_snes, &its);
  SNESGetLinearSolveIterations(_snes, &lits);
  report.iterations = its + _full_steps;
  const long inner = _formulation->inner_iterations();
  report.linear_iterations = inner < 0 ? lits : inner - inner_iterations_before;
  PetscReal* history;
  PetscInt n;
  SNESGetConvergenceHistory(_snes, &history, nullptr, &n);
  report.residual_norms.assign(history, history + n);
  report.step_lengths = _step_lengths;
  report.kernel = _last_kernel;
  report.non_finite = _non_finite;
  return report;
}

} // namespace muscle
