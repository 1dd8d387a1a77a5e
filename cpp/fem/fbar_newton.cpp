// Three-field F-bar Newton: the SNES vector is [u part | cells of part 0 | ...],
// the cell unknowns theta, p eliminated per cell around a condensed
// displacement solve (FbarCellUnknowns).
#include "nonlinear_solver.h"

#include "constraint.h"
#include "fbar_unknowns.h"
#include "linear_failure.h"

#include <algorithm>
#include <cmath>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/la/petsc.h>
#include <limits>

using namespace dolfinx;

namespace muscle
{

void NonlinearSolver::create_cell_unknowns()
{
  for (MuscleProblem* part : _parts)
  {
    part->hold_fbar_theta(true);
    _cell_unknowns.push_back(std::make_unique<FbarCellUnknowns>(*part, _bcs));
  }
  MPI_Comm comm = _problem.mesh()->comm();
  PetscInt n;
  VecGetLocalSize(_x, &n);
  for (const auto& cells : _cell_unknowns)
    n += cells->size();
  VecCreateMPI(comm, n, PETSC_DETERMINE, &_x_ext);
  MatCreateShell(comm, n, n, PETSC_DETERMINE, PETSC_DETERMINE, this, &_J_ext);
  MatShellSetOperation(_J_ext, MATOP_MULT, (void (*)(void))extended_multiply);
  for (Vec* v : {&_rhs, &_sol, &_tmp})
    VecDuplicate(_x, v);
  KSPCreate(comm, &_inner);
  if (_constraint and _options.linear_solver != "gmres-schur")
  {
    // P^T A P needs an assembled A for its symbolic phase (the penalty split forms
    // its T^T A_s T at its first Jacobian)
    _problem.u()->x()->scatter_fwd();
    for (auto& cells : _cell_unknowns)
      cells->initialise();
    assemble_three_field_jacobian();
  }
}

void NonlinearSolver::start_three_field()
{
  // theta = J0(u), p = r_0: the converged state's own cell unknowns
  _problem.u()->x()->scatter_fwd();
  for (auto& cells : _cell_unknowns)
    cells->initialise();
  PetscScalar* a;
  VecGetArray(_x_ext, &a);
  Blocks b = blocks(a);
  const PetscScalar* xu;
  VecGetArrayRead(_x, &xu);
  std::copy(xu, xu + b.u.size(), b.u.begin());
  VecRestoreArrayRead(_x, &xu);
  for (std::size_t i = 0; i < _cell_unknowns.size(); ++i)
    _cell_unknowns[i]->get(b.cells[i]);
  VecRestoreArray(_x_ext, &a);
  first_full_step();
}

namespace
{
/// SNESSolve with full Newton steps (line search basic) and at most `max_it`
/// iterations; the line search's type and tolerances and the SNES's own as they were
/// (the user's -snes_* and -snes_linesearch_* included: setting a type anew resets them).
PetscErrorCode solve_with_full_steps(SNES snes, Vec x, PetscInt max_it)
{
  SNESLineSearch ls;
  SNESGetLineSearch(snes, &ls);
  SNESLineSearchType type;
  SNESLineSearchGetType(ls, &type);
  const std::string previous = type;
  PetscReal steptol, maxstep, rtol, atol, ltol, snes_atol, snes_rtol, snes_stol;
  PetscInt ls_max_it, snes_max_it, max_funcs;
  SNESLineSearchGetTolerances(ls, &steptol, &maxstep, &rtol, &atol, &ltol, &ls_max_it);
  PetscInt order;
  SNESLineSearchGetOrder(ls, &order);
  SNESGetTolerances(snes, &snes_atol, &snes_rtol, &snes_stol, &snes_max_it, &max_funcs);
  SNESLineSearchSetType(ls, SNESLINESEARCHBASIC);
  SNESSetTolerances(snes, snes_atol, snes_rtol, snes_stol, max_it, max_funcs);
  const PetscErrorCode error = SNESSolve(snes, nullptr, x);
  SNESLineSearchSetType(ls, previous.c_str());
  SNESLineSearchSetTolerances(ls, steptol, maxstep, rtol, atol, ltol, ls_max_it);
  SNESLineSearchSetOrder(ls, order);
  SNESSetTolerances(snes, snes_atol, snes_rtol, snes_stol, snes_max_it, max_funcs);
  return error;
}
} // namespace

void NonlinearSolver::first_full_step()
{
  // The three-field system keeps its Dirichlet columns (no lifting), so a
  // boundary value that moved stands in the residual as rows u - g, which are
  // no gradient of the energy: the critical-point line search then stalls (a
  // stiff block pulled at its top: 45 Newton iterations, no convergence).  One
  // full Newton step puts g in u and carries the interior along; if that step
  // leaves the admissible states, the solve starts from the old state as before.
  _full_steps = 0;
  auto u = _problem.u()->x();
  la::Vector<double> g(*u);
  std::span<double> ga = g.mutable_array();
  for (const auto& bc : _bcs)
    bc->set(ga);
  double moved = 0;
  const std::int32_t owned = u->map()->size_local() * u->bs();
  for (std::int32_t i = 0; i < owned; ++i)
    moved = std::max(moved, std::abs(ga[i] - u->array()[i]));
  MPI_Allreduce(MPI_IN_PLACE, &moved, 1, MPI_DOUBLE, MPI_MAX, _problem.mesh()->comm());
  // (a trust region, -snes_type newtontr, has no line search to stall)
  if (!(moved > 0) or _options.line_search == "basic" or line_search().empty())
    return;
  Vec start;
  VecDuplicate(_x_ext, &start);
  VecCopy(_x_ext, start);
  const PetscErrorCode error = solve_with_full_steps(_snes, _x_ext, 1);
  SNESConvergedReason reason;
  SNESGetConvergedReason(_snes, &reason);
  // a failed linear solve took no step; its failure must not fail the solve after it
  if (error or reason == SNES_DIVERGED_FUNCTION_DOMAIN
      or reason == SNES_DIVERGED_LINEAR_SOLVE or _non_finite)
    VecCopy(start, _x_ext);
  else
    _full_steps = 1;
  start_clean();
  VecDestroy(&start);
}

bool NonlinearSolver::zero_update() const
{
  Vec dx;
  PetscReal norm = 0;
  SNESGetSolutionUpdate(_snes, &dx);
  return dx and !VecNorm(dx, NORM_2, &norm) and !(norm > 0);
}

bool NonlinearSolver::stopped_short_of_theta() const
{
  SNESConvergedReason reason;
  SNESGetConvergedReason(_snes, &reason);
  return reason > 0 and _test_verdict <= 0 and !_cell_unknowns.empty() and !line_search().empty()
         and !(_constraint_violation <= _options.fbar_constraint_tolerance)
         and !zero_update();
}

PetscErrorCode NonlinearSolver::finish_theta_with_full_steps()
{
  // cp stops where dot(F, dx) is below its atol, and theta's rows are tiny in that
  // product: it can stop with the residual at round-off and theta still away from
  // J0(u) (seen at kappa = 10^4: 1.1e-10 against the tolerance 1e-10), a state the
  // convergence test refused.  Newton's full step closes the constraint.
  PetscInt its, max_it;
  SNESGetIterationNumber(_snes, &its);
  SNESGetTolerances(_snes, nullptr, nullptr, nullptr, &max_it, nullptr);
  _full_steps += its;
  _test_verdict = SNES_CONVERGED_ITERATING;
  return solve_with_full_steps(_snes, _x_ext, std::max<PetscInt>(1, max_it - _full_steps));
}

NonlinearSolver::Blocks NonlinearSolver::blocks(double* array) const
{
  PetscInt n;
  VecGetLocalSize(_x, &n);
  Blocks b{std::span<double>(array, n), {}};
  for (const auto& cells : _cell_unknowns)
  {
    b.cells.emplace_back(array + n, cells->size());
    n += cells->size();
  }
  return b;
}

void NonlinearSolver::set_extended_state(Vec x_ext)
{
  const PetscScalar* a;
  VecGetArrayRead(x_ext, &a);
  Blocks b = blocks(const_cast<double*>(a));
  PetscScalar* xu;
  VecGetArray(_tmp, &xu);
  std::copy(b.u.begin(), b.u.end(), xu);
  VecRestoreArray(_tmp, &xu);
  for (std::size_t i = 0; i < _cell_unknowns.size(); ++i)
    _cell_unknowns[i]->set(b.cells[i]);
  VecRestoreArrayRead(x_ext, &a);
  set_state(_tmp);
}

void NonlinearSolver::extended_residual(Vec F_ext)
{
  std::span<double> b = _b.mutable_array();
  std::fill(b.begin(), b.end(), 0.0);
  PetscScalar* f;
  VecGetArray(F_ext, &f);
  Blocks fb = blocks(f);
  double violation = 0;
  for (std::size_t i = 0; i < _cell_unknowns.size(); ++i)
  {
    const double v = _cell_unknowns[i]->residual(b, fb.cells[i]);
    violation = std::isnan(v) ? std::numeric_limits<double>::infinity()
                              : std::max(violation, v);
  }
  MPI_Allreduce(MPI_IN_PLACE, &violation, 1, MPI_DOUBLE, MPI_MAX, _problem.mesh()->comm());
  _constraint_violation = std::isinf(violation) ? std::numeric_limits<double>::quiet_NaN()
                                                : violation;
  for (const auto& r : _extra_residuals)
    fem::assemble_vector<double>(b, *r);
  // no lifting: the Newton matrix keeps the Dirichlet columns (FbarCellUnknowns)
  std::span<const double> u = _problem.u()->x()->array();
  _b.scatter_rev(std::plus<double>());
  add_term_residuals(b);
  fem::set_bc<double>(b, _bcs, u, -1.0);
  if (_constraint)
  {
    MatMultTranspose(_constraint->T(), _F_full, _tmp);
    const PetscScalar* t;
    VecGetArrayRead(_tmp, &t);
    std::copy(t, t + fb.u.size(), fb.u.begin());
    VecRestoreArrayRead(_tmp, &t);
  }
  else
    std::copy(b.begin(), b.begin() + fb.u.size(), fb.u.begin());
  VecRestoreArray(F_ext, &f);
}

void NonlinearSolver::assemble_three_field_jacobian()
{
  MatZeroEntries(_A);
  for (auto& cells : _cell_unknowns)
    cells->jacobian(_A);
  close_jacobian();
  // the cells' blocks enter the recovery, also where all their dofs are fixed
  int cells_finite = 1;
  for (const auto& cells : _cell_unknowns)
    cells_finite = cells_finite and cells->linearisation_is_finite();
  MPI_Allreduce(MPI_IN_PLACE, &cells_finite, 1, MPI_INT, MPI_MIN, _problem.mesh()->comm());
  if (!cells_finite)
    _matrix_norm = std::numeric_limits<double>::quiet_NaN();
  if (!std::isfinite(_matrix_norm))
    return;
  Mat K = _A;
  // the penalty split solves with T^T A_s T only: forming T^T A T as well cost the free
  // fusiform a quarter of its memory (n = 3) and a second product per Newton iteration
  if (_constraint and !_soft)
  {
    const bool first = !_A_red;
    reduce(_A_red, first);
    if (first and _near_null_space)
      MatSetNearNullSpace(_A_red, _near_null_space);
    K = _A_red;
  }
  KSPSetOperators(_inner, K, K);
  if (_soft)
    update_penalty_split();
}

PetscErrorCode NonlinearSolver::condensed_solve(PC pc, Vec b_ext, Vec y_ext)
{
  NonlinearSolver* self;
  PCShellGetContext(pc, &self);
  const PetscScalar* bb;
  VecGetArrayRead(b_ext, &bb);
  Blocks B = self->blocks(const_cast<double*>(bb));
  // K du = b_u + the cells' condensed terms
  std::span<double> w = self->_work.mutable_array();
  std::fill(w.begin(), w.end(), 0.0);
  for (std::size_t i = 0; i < self->_cell_unknowns.size(); ++i)
    self->_cell_unknowns[i]->condense(B.cells[i], w);
  self->_work.scatter_rev(std::plus<double>());
  PetscScalar* r;
  VecGetArray(self->_rhs, &r);
  std::copy(B.u.begin(), B.u.end(), r);
  VecRestoreArray(self->_rhs, &r);
  self->add_restricted(self->_work, self->_rhs);
  // a failing inner solve (or a PETSc error in it) fails this linear solve:
  // SNES stops with DIVERGED_LINEAR_SOLVE and the stepper cuts the step --
  // never a direction from garbage
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
  PetscErrorCode error;
  PetscInt its = 0;
  if (self->_soft)
  {
    its = self->saddle_solve(); // gmres-schur (penalty_split.cpp)
    error = self->_linear_error;
  }
  else
  {
    error = KSPSolve(self->_inner, self->_rhs, self->_sol);
    KSPGetIterationNumber(self->_inner, &its);
  }
  PetscPopErrorHandler();
  self->_inner_iterations += its;
  KSPConvergedReason reason = KSP_DIVERGED_PC_FAILED;
  self->_linear_error = error;
  if (!error)
    KSPGetConvergedReason(self->_inner, &reason);
  // an error can be one rank's alone, and the recovery below is collective
  int failed = reason < 0;
  MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_LOR,
                PetscObjectComm(reinterpret_cast<PetscObject>(pc)));
  if (failed)
  {
    VecRestoreArrayRead(b_ext, &bb);
    fail_shell_apply(pc, y_ext);
    return 0;
  }
  // dtheta, dp from du
  self->to_full(self->_sol);
  PetscScalar* yy;
  VecGetArray(y_ext, &yy);
  Blocks Y = self->blocks(yy);
  const PetscScalar* du;
  VecGetArrayRead(self->_sol, &du);
  std::copy(du, du + Y.u.size(), Y.u.begin());
  VecRestoreArrayRead(self->_sol, &du);
  for (std::size_t i = 0; i < self->_cell_unknowns.size(); ++i)
    self->_cell_unknowns[i]->recover(self->_work.array(), B.cells[i], Y.cells[i]);
  VecRestoreArray(y_ext, &yy);
  VecRestoreArrayRead(b_ext, &bb);
  return 0;
}

PetscErrorCode NonlinearSolver::extended_multiply(Mat J, Vec v, Vec y)
{
  NonlinearSolver* self;
  MatShellGetContext(J, &self);
  const PetscScalar* vv;
  VecGetArrayRead(v, &vv);
  Blocks V = self->blocks(const_cast<double*>(vv));
  PetscScalar* t;
  VecGetArray(self->_tmp, &t);
  std::copy(V.u.begin(), V.u.end(), t);
  VecRestoreArray(self->_tmp, &t);
  self->to_full(self->_tmp);
  if (self->_constraint and self->_soft)
    self->multiply_reduced(self->_sol); // the penalty split keeps no T^T A T
  else
    MatMult(self->_constraint ? self->_A_red : self->_A, self->_tmp, self->_sol);
  std::span<double> w2 = self->_work2.mutable_array();
  std::fill(w2.begin(), w2.end(), 0.0);
  PetscScalar* yy;
  VecGetArray(y, &yy);
  Blocks Y = self->blocks(yy);
  for (std::size_t i = 0; i < self->_cell_unknowns.size(); ++i)
    self->_cell_unknowns[i]->multiply(self->_work.array(), V.cells[i], w2, Y.cells[i]);
  self->_work2.scatter_rev(std::plus<double>());
  self->add_restricted(self->_work2, self->_sol);
  const PetscScalar* s;
  VecGetArrayRead(self->_sol, &s);
  std::copy(s, s + Y.u.size(), Y.u.begin());
  VecRestoreArrayRead(self->_sol, &s);
  VecRestoreArray(y, &yy);
  VecRestoreArrayRead(v, &vv);
  return 0;
}

} // namespace muscle
