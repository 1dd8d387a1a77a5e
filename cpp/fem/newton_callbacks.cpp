// What SNES calls back during a solve: the residual and the Jacobian at an
// iterate (displacement Newton, or three-field F-bar through fbar_newton.cpp)
// and the convergence test.
#include "nonlinear_solver.h"

#include "constraint.h"

#include <cmath>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/la/petsc.h>
#include <limits>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// The infinity norm (the scale of the round-off floor), or NaN when any entry
/// is not finite: PETSc's infinity norm skips a NaN row sum, the Frobenius
/// norm propagates it.
double finite_norm(Mat A)
{
  PetscReal inf, frobenius;
  MatNorm(A, NORM_INFINITY, &inf);
  MatNorm(A, NORM_FROBENIUS, &frobenius);
  return std::isfinite(frobenius) ? inf : std::numeric_limits<double>::quiet_NaN();
}
} // namespace

void NonlinearSolver::set_state(Vec x)
{
  auto u = _problem.u();
  if (_constraint)
    _constraint->prolong(x, *u->x());
  else
  {
    VecCopy(x, _u_petsc);
    u->x()->scatter_fwd();
  }
  _last_kernel = update_activation();
}

void NonlinearSolver::add_term_residuals(std::span<double> b) const
{
  if (_terms.empty())
    return;
  VecZeroEntries(_term_F);
  for (const auto& t : _terms)
    t->add_residual(_term_F);
  VecAssemblyBegin(_term_F);
  VecAssemblyEnd(_term_F);
  const PetscScalar* f;
  PetscInt n;
  VecGetLocalSize(_term_F, &n);
  VecGetArrayRead(_term_F, &f);
  for (PetscInt i = 0; i < n; ++i)
    b[i] += f[i];
  VecRestoreArrayRead(_term_F, &f);
}

PetscErrorCode NonlinearSolver::residual_callback(SNES snes, Vec x, Vec F, void* ctx)
{
  auto* self = static_cast<NonlinearSolver*>(ctx);
  if (!self->_cell_unknowns.empty())
  {
    self->set_extended_state(x);
    self->extended_residual(F);
  }
  else if (self->_taylor_hood)
  {
    self->set_mixed_state(x);
    self->mixed_residual(F);
  }
  else
  {
    self->set_state(x);
    self->displacement_residual();
    if (self->_constraint)
      MatMultTranspose(self->_constraint->T(), self->_F_full, F);
    else
      VecCopy(self->_b_petsc, F);
  }
  // (the constraint violation stays 0 without F-bar cell unknowns)
  PetscReal norm;
  VecNorm(F, NORM_2, &norm);
  if (!std::isfinite(norm) or !std::isfinite(self->_constraint_violation)
      or !self->_last_kernel.ok())
  {
    self->_non_finite = self->_non_finite or !std::isfinite(norm);
    SNESSetFunctionDomainError(snes);
  }
  return 0;
}

void NonlinearSolver::displacement_residual()
{
  std::span<double> b = _b.mutable_array();
  std::fill(b.begin(), b.end(), 0.0);
  std::span<const double> u = _problem.u()->x()->array();
  for (MuscleProblem* part : _parts)
  {
    fem::assemble_vector<double>(b, *part->residual());
    fem::apply_lifting<double>(b, {part->jacobian()}, {_bcs}, {u}, -1.0);
  }
  for (const auto& r : _extra_residuals)
    fem::assemble_vector<double>(b, *r);
  for (const auto& J : _extra_jacobians)
    fem::apply_lifting<double>(b, {J}, {_bcs}, {u}, -1.0);
  _b.scatter_rev(std::plus<double>());
  add_term_residuals(b);
  fem::set_bc<double>(b, _bcs, u, -1.0);
}

void NonlinearSolver::assemble_full_jacobian()
{
  MatZeroEntries(_A);
  for (MuscleProblem* part : _parts)
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(_A, ADD_VALUES), *part->jacobian(),
                         _bcs);
  close_jacobian();
}

void NonlinearSolver::close_jacobian()
{
  for (const auto& J : _extra_jacobians)
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(_A, ADD_VALUES), *J, _bcs);
  for (const auto& t : _terms)
    t->add_jacobian(_A);
  MatAssemblyBegin(_A, MAT_FLUSH_ASSEMBLY);
  MatAssemblyEnd(_A, MAT_FLUSH_ASSEMBLY);
  fem::set_diagonal<double>(la::petsc::Matrix::set_fn(_A, INSERT_VALUES), *_problem.V(), _bcs);
  MatAssemblyBegin(_A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_A, MAT_FINAL_ASSEMBLY);
  _matrix_norm = finite_norm(_A);
}

PetscErrorCode NonlinearSolver::jacobian_callback(SNES snes, Vec x, Mat J, Mat, void* ctx)
{
  auto* self = static_cast<NonlinearSolver*>(ctx);
  const bool three_field = !self->_cell_unknowns.empty();
  if (three_field)
  {
    self->set_extended_state(x);
    self->assemble_three_field_jacobian();
  }
  else if (self->_taylor_hood)
  {
    self->set_mixed_state(x);
    self->assemble_mixed_jacobian();
  }
  else
  {
    self->set_state(x);
    self->assemble_full_jacobian();
  }
  // The tangent can overflow where the residual is still finite (the coupled
  // penalty's tangent carries an extra (2 kappa)^2): report it, never solve with it
  if (!std::isfinite(self->_matrix_norm))
  {
    self->_non_finite = true;
    SNESSetJacobianDomainError(snes);
    return 0;
  }
  // (three-field, Taylor-Hood: the matrices are reduced with their assembly)
  if (!three_field and !self->_taylor_hood and self->_constraint)
    self->reduce(J, false);
  return 0;
}

PetscErrorCode NonlinearSolver::convergence_test(SNES snes, PetscInt it,
                                                 PetscReal xnorm, PetscReal ynorm,
                                                 PetscReal fnorm,
                                                 SNESConvergedReason* reason,
                                                 void* ctx)
{
  SNESConvergedDefault(snes, it, xnorm, ynorm, fnorm, reason, nullptr);
  auto* self = static_cast<NonlinearSolver*>(ctx);
  // A residual cannot be computed more accurately than round-off in the
  // largest element forces, eps |J| |x|; with a stiff penalty that floor can
  // lie above any fixed atol, and Newton would stagnate there.
  // (three-field: |x| of the displacement block only -- theta and p have other
  // units.  Taylor-Hood: mixed_floor)
  const double floor
      = self->_taylor_hood
            ? 100 * self->mixed_floor(snes)
            : 100 * std::numeric_limits<double>::epsilon() * self->_matrix_norm
                  * (self->_cell_unknowns.empty() ? xnorm : self->displacement_norm(snes));
  if (*reason == SNES_CONVERGED_ITERATING and std::isfinite(floor) and fnorm <= floor)
    *reason = SNES_CONVERGED_FNORM_ABS;
  // three-field: converged only once theta = J0(u) too (R_p is tiny in the norm)
  if (*reason > 0 and !self->_cell_unknowns.empty()
      and !(self->_constraint_violation <= self->_options.fbar_constraint_tolerance))
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
  self->_test_verdict = *reason;
  return 0;
}

double NonlinearSolver::displacement_norm(SNES snes) const
{
  Vec x;
  SNESGetSolution(snes, &x);
  const PetscScalar* a;
  VecGetArrayRead(x, &a);
  PetscInt n;
  VecGetLocalSize(_x, &n);
  double sum = 0;
  for (PetscInt i = 0; i < n; ++i)
    sum += a[i] * a[i];
  VecRestoreArrayRead(x, &a);
  MPI_Allreduce(MPI_IN_PLACE, &sum, 1, MPI_DOUBLE, MPI_SUM, _problem.mesh()->comm());
  return std::sqrt(sum);
}

} // namespace muscle
