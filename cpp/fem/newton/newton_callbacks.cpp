// What SNES calls back during a solve: the residual and the Jacobian at an
// iterate (through the formulation) and the convergence test.
#include "fem/newton/formulation.h"
#include "fem/newton/nonlinear_solver.h"

#include <cmath>

namespace muscle
{

PetscErrorCode NonlinearSolver::residual_callback(SNES snes, Vec x, Vec F, void* ctx)
{
  auto* self = static_cast<NonlinearSolver*>(ctx);
  self->_last_kernel = self->_formulation->set_state(x);
  self->_formulation->residual(F);
  PetscReal norm;
  VecNorm(F, NORM_2, &norm);
  const double violation = self->_formulation->constraint_violation();
  if (!std::isfinite(norm) or !std::isfinite(violation) or !self->_last_kernel.ok())
  {
    self->_non_finite = self->_non_finite or !std::isfinite(norm);
    SNESSetFunctionDomainError(snes);
  }
  return 0;
}

PetscErrorCode NonlinearSolver::jacobian_callback(SNES snes, Vec x, Mat, Mat, void* ctx)
{
  auto* self = static_cast<NonlinearSolver*>(ctx);
  self->_last_kernel = self->_formulation->set_state(x);
  self->_formulation->jacobian();
  // The tangent can overflow where the residual is still finite (the coupled
  // penalty's tangent carries an extra (2 kappa)^2): report it, never solve with it
  if (!std::isfinite(self->_formulation->matrix_norm()))
  {
    self->_non_finite = true;
    SNESSetJacobianDomainError(snes);
  }
  return 0;
}

PetscErrorCode NonlinearSolver::trust_region_linear_check(KSP ksp, Vec, Vec, void* ctx)
{
  // PETSc 3.18's NEWTONTR takes any direction its KSP returns: a failed solve's
  // (Inf from a failed shell, an unfinished Krylov iterate) shrinks the region to
  // DIVERGED_TR_DELTA, and the stop would blame the time step.  (A Krylov solve
  // stopped at the region's radius, KSP_CONVERGED_STEP_LENGTH, is the method's own.)
  // (preonly sets its failure on the failing rank only: agreed over all)
  KSPConvergedReason reason;
  KSPGetConvergedReason(ksp, &reason);
  int failed = reason < 0;
  MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_LOR,
                PetscObjectComm(reinterpret_cast<PetscObject>(ksp)));
  if (!failed)
    return 0;
  static_cast<NonlinearSolver*>(ctx)->_trust_region_linear_failure = true;
  SETERRQ(PetscObjectComm(reinterpret_cast<PetscObject>(ksp)), PETSC_ERR_NOT_CONVERGED,
          "the linear solve failed inside the trust region");
}

PetscErrorCode NonlinearSolver::convergence_test(SNES snes, PetscInt it, PetscReal xnorm,
                                                 PetscReal ynorm, PetscReal fnorm,
                                                 SNESConvergedReason* reason, void* ctx)
{
  SNESConvergedDefault(snes, it, xnorm, ynorm, fnorm, reason, nullptr);
  auto* self = static_cast<NonlinearSolver*>(ctx);
  const double floor = self->_formulation->convergence_floor(snes, xnorm);
  if (*reason == SNES_CONVERGED_ITERATING and std::isfinite(floor) and fnorm <= floor)
    *reason = SNES_CONVERGED_FNORM_ABS;
  // converged only once the formulation's constraint is met too (F-bar's theta =
  // J0(u): R_p is tiny in the norm)
  if (*reason > 0
      and !(self->_formulation->constraint_violation() <= self->_options.fbar_constraint_tolerance))
    *reason = SNES_CONVERGED_ITERATING;
  if (it == 0)
  {
    self->_norms.clear();
    self->_step_lengths.clear();
  }
  self->_norms.push_back(fnorm);
  // the step the line search took (stop messages judge the line search by it);
  // a trust region has none
  PetscBool line_search;
  PetscObjectTypeCompare(reinterpret_cast<PetscObject>(snes), SNESNEWTONLS, &line_search);
  if (it > 0 and line_search)
  {
    SNESLineSearch ls;
    SNESGetLineSearch(snes, &ls);
    PetscReal lambda;
    SNESLineSearchGetLambda(ls, &lambda);
    self->_step_lengths.push_back(lambda);
  }
  const int window = self->_options.stagnation_window;
  if (*reason == SNES_CONVERGED_ITERATING and window > 0 and it >= window
      and fnorm > (1 - self->_options.stagnation_reduction) * self->_norms[it - window])
  {
    self->_stagnated = true;
    *reason = SNES_DIVERGED_MAX_IT;
  }
  if (*reason == SNES_CONVERGED_ITERATING and self->creeping())
  {
    self->_crept = true;
    *reason = SNES_DIVERGED_MAX_IT;
  }
  self->_test_verdict = *reason;
  return 0;
}

} // namespace muscle
