// Three-field F-bar Newton: the SNES vector is [u part | cells of part 0 | ...],
// the cell unknowns theta, p eliminated per cell around a condensed
// displacement solve (FbarCellUnknowns).
#include "fem/newton/fbar_formulation.h"

#include "common/errors.h"
#include "fem/constraints/constraint.h"
#include "fem/elements/fbar_unknowns.h"
#include "fem/linear/linear_failure.h"
#include "fem/linear/linear_solvers.h"
#include "fem/linear/penalty_split.h"
#include "fem/linear/taylor_hood_split.h"
#include "fem/newton/displacement_system.h"

#include <algorithm>
#include <cmath>
#include <dolfinx/la/petsc.h>
#include <limits>

using namespace dolfinx;

namespace muscle
{

FbarFormulation::FbarFormulation(DisplacementSystem& system, const NewtonOptions& options)
    : _system(system), _work(_system.b()), _work2(_system.b())
{
  const LinearSolverType& type = linear_solver_type(options.linear_solver);
  if (!type.condensed and !type.matrix)
    refuse_without_pressure(type);
  refuse_taylor_hood_split_options(false, options.linear_solver);
  const DisplacementConstraint* constraint = _system.constraint();
  MuscleProblem& problem = _system.problem();
  _x = _system.create_unknowns();
  for (MuscleProblem* part : _system.parts())
  {
    part->hold_fbar_theta(true);
    _cells.push_back(std::make_unique<FbarCellUnknowns>(*part, _system.bcs()));
  }
  MPI_Comm comm = _system.comm();
  PetscInt n;
  VecGetLocalSize(_x, &n);
  for (const auto& cells : _cells)
    n += cells->size();
  VecCreateMPI(comm, n, PETSC_DETERMINE, _x_ext.out());
  MatCreateShell(comm, n, n, PETSC_DETERMINE, PETSC_DETERMINE, this, _J_ext.out());
  MatShellSetOperation(_J_ext, MATOP_MULT, (void (*)(void))extended_multiply);
  VecDuplicate(_x, _rhs.out());
  VecDuplicate(_x, _sol.out());
  VecDuplicate(_x, _tmp.out());
  KSPCreate(comm, _inner.out());
  const DisplacementSpace space{problem.V(), constraint};
  if (type.condensed)
    _split = type.condensed(options, space, _cells, _system.A(), _x);
  else
  {
    _matrix_solver = type.matrix(options, space);
    _system.set_reduced_block_size(_matrix_solver->reduced_block_size());
  }
  if (constraint and !_split)
  {
    // P^T A P needs an assembled A for its symbolic phase (the penalty split forms
    // its T^T A_s T at its first Jacobian)
    problem.u()->x()->scatter_fwd();
    for (auto& cells : _cells)
      cells->initialise();
    jacobian();
  }
}

FbarFormulation::~FbarFormulation() = default;

const LinearSolver& FbarFormulation::linear_solver() const
{
  return _split ? static_cast<const LinearSolver&>(*_split) : *_matrix_solver;
}

std::vector<KSP> FbarFormulation::nested() const
{
  std::vector<KSP> ksps = linear_solver().nested();
  ksps.insert(ksps.begin(), _inner);
  return ksps;
}

void FbarFormulation::start_clean()
{
  _linear_error = 0;
  _split ? _split->start_solve() : _matrix_solver->start_solve();
}

Mat FbarFormulation::condensed() const
{
  return _system.constraint() ? _system.reduced() : _system.A();
}

void FbarFormulation::configure_linear_solver(KSP)
{
  // PETSc's -ksp_* and -pc_* options configure the condensed solve (after_options);
  // the SNES's own KSP only eliminates and recovers the cell unknowns around it
  if (_split)
    _split->configure(_inner);
  else
  {
    _matrix_solver->configure(_inner);
    if (Mat K = condensed())
      _matrix_solver->operator_made(_system.A(), K);
  }
}

void FbarFormulation::after_options(KSP ksp)
{
  KSPSetFromOptions(_inner);
  KSPSetType(ksp, KSPPREONLY);
  PC pc;
  KSPGetPC(ksp, &pc);
  PCSetType(pc, PCSHELL);
  PCShellSetContext(pc, this);
  PCShellSetApply(pc, condensed_solve);
  PCShellSetName(pc, "F-bar cell unknowns eliminated around the condensed solve");
}

void FbarFormulation::start()
{
  // theta = J0(u), p = r_0: the converged state's own cell unknowns
  _system.get_unknowns(_x);
  _system.problem().u()->x()->scatter_fwd();
  for (auto& cells : _cells)
    cells->initialise();
  PetscScalar* a;
  VecGetArray(_x_ext, &a);
  Blocks b = blocks(a);
  const PetscScalar* xu;
  VecGetArrayRead(_x, &xu);
  std::copy(xu, xu + b.u.size(), b.u.begin());
  VecRestoreArrayRead(_x, &xu);
  for (std::size_t i = 0; i < _cells.size(); ++i)
    _cells[i]->get(b.cells[i]);
  VecRestoreArray(_x_ext, &a);
}

FbarFormulation::Blocks FbarFormulation::blocks(double* array) const
{
  PetscInt n;
  VecGetLocalSize(_x, &n);
  Blocks b{std::span<double>(array, n), {}};
  for (const auto& cells : _cells)
  {
    b.cells.emplace_back(array + n, cells->size());
    n += cells->size();
  }
  return b;
}

KernelStatus FbarFormulation::set_state(Vec x_ext)
{
  const PetscScalar* a;
  VecGetArrayRead(x_ext, &a);
  Blocks b = blocks(const_cast<double*>(a));
  PetscScalar* xu;
  VecGetArray(_tmp, &xu);
  std::copy(b.u.begin(), b.u.end(), xu);
  VecRestoreArray(_tmp, &xu);
  for (std::size_t i = 0; i < _cells.size(); ++i)
    _cells[i]->set(b.cells[i]);
  VecRestoreArrayRead(x_ext, &a);
  _system.set_unknowns(_tmp);
  return _system.update_activation();
}

void FbarFormulation::residual(Vec F_ext)
{
  PetscScalar* f;
  VecGetArray(F_ext, &f);
  Blocks fb = blocks(f);
  // no lifting: the Newton matrix keeps the Dirichlet columns (FbarCellUnknowns)
  _system.unlifted_residual([&](std::span<double> b)
  {
    double violation = 0;
    for (std::size_t i = 0; i < _cells.size(); ++i)
    {
      const double v = _cells[i]->residual(b, fb.cells[i]);
      violation = std::isnan(v) ? std::numeric_limits<double>::infinity()
                                : std::max(violation, v);
    }
    MPI_Allreduce(MPI_IN_PLACE, &violation, 1, MPI_DOUBLE, MPI_MAX, _system.comm());
    _constraint_violation = std::isinf(violation) ? std::numeric_limits<double>::quiet_NaN()
                                                  : violation;
  });
  _system.restrict_residual(_tmp);
  const PetscScalar* t;
  VecGetArrayRead(_tmp, &t);
  std::copy(t, t + fb.u.size(), fb.u.begin());
  VecRestoreArrayRead(_tmp, &t);
  VecRestoreArray(F_ext, &f);
}

void FbarFormulation::jacobian()
{
  Mat A = _system.A();
  MatZeroEntries(A);
  for (auto& cells : _cells)
    cells->jacobian(A);
  _system.close_jacobian();
  // the cells' blocks enter the recovery, also where all their dofs are fixed
  int cells_finite = 1;
  for (const auto& cells : _cells)
    cells_finite = cells_finite and cells->linearisation_is_finite();
  MPI_Allreduce(MPI_IN_PLACE, &cells_finite, 1, MPI_INT, MPI_MIN, _system.comm());
  if (!cells_finite)
    _system.set_matrix_norm(std::numeric_limits<double>::quiet_NaN());
  if (!std::isfinite(_system.matrix_norm()))
    return;
  // the penalty split solves with T^T A_s T only: forming T^T A T as well costs the
  // free fusiform memory and a second product per Newton iteration (BENCHMARKS.md,
  // "The uniform meshes: F-bar n = 1, 2, 3, 4, 6")
  if (_system.constraint() and !_split)
    _system.reduce();
  Mat K = _split ? A : condensed();
  KSPSetOperators(_inner, K, K);
  if (_split)
    _split->update();
}

double FbarFormulation::matrix_norm() const { return _system.matrix_norm(); }

double FbarFormulation::convergence_floor(SNES snes, double) const
{
  // |x| of the displacement block only -- theta and p have other units
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
  MPI_Allreduce(MPI_IN_PLACE, &sum, 1, MPI_DOUBLE, MPI_SUM, _system.comm());
  return 100 * std::numeric_limits<double>::epsilon() * _system.matrix_norm() * std::sqrt(sum);
}

PetscErrorCode FbarFormulation::condensed_solve(PC pc, Vec b_ext, Vec y_ext)
{
  FbarFormulation* self;
  PCShellGetContext(pc, &self);
  const DisplacementConstraint* constraint = self->_system.constraint();
  const PetscScalar* bb;
  VecGetArrayRead(b_ext, &bb);
  Blocks B = self->blocks(const_cast<double*>(bb));
  // K du = b_u + the cells' condensed terms
  std::span<double> w = self->_work.mutable_array();
  std::fill(w.begin(), w.end(), 0.0);
  for (std::size_t i = 0; i < self->_cells.size(); ++i)
    self->_cells[i]->condense(B.cells[i], w);
  self->_work.scatter_rev(std::plus<double>());
  PetscScalar* r;
  VecGetArray(self->_rhs, &r);
  std::copy(B.u.begin(), B.u.end(), r);
  VecRestoreArray(self->_rhs, &r);
  add_restricted(constraint, self->_work, self->_rhs);
  // a failing inner solve (or a PETSc error in it) fails this linear solve:
  // SNES stops with DIVERGED_LINEAR_SOLVE and the stepper cuts the step --
  // never a direction from garbage
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
  PetscErrorCode error;
  PetscInt its = 0;
  if (self->_split)
    std::tie(error, its) = self->_split->solve(self->_rhs, self->_sol);
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
  to_full(constraint, self->_sol, self->_work);
  PetscScalar* yy;
  VecGetArray(y_ext, &yy);
  Blocks Y = self->blocks(yy);
  const PetscScalar* du;
  VecGetArrayRead(self->_sol, &du);
  std::copy(du, du + Y.u.size(), Y.u.begin());
  VecRestoreArrayRead(self->_sol, &du);
  for (std::size_t i = 0; i < self->_cells.size(); ++i)
    self->_cells[i]->recover(self->_work.array(), B.cells[i], Y.cells[i]);
  VecRestoreArray(y_ext, &yy);
  VecRestoreArrayRead(b_ext, &bb);
  return 0;
}

PetscErrorCode FbarFormulation::extended_multiply(Mat J, Vec v, Vec y)
{
  FbarFormulation* self;
  MatShellGetContext(J, &self);
  const DisplacementConstraint* constraint = self->_system.constraint();
  const PetscScalar* vv;
  VecGetArrayRead(v, &vv);
  Blocks V = self->blocks(const_cast<double*>(vv));
  PetscScalar* t;
  VecGetArray(self->_tmp, &t);
  std::copy(V.u.begin(), V.u.end(), t);
  VecRestoreArray(self->_tmp, &t);
  to_full(constraint, self->_tmp, self->_work);
  if (constraint and self->_split)
    self->_system.multiply_reduced(self->_work, self->_sol); // the split keeps no T^T A T
  else
    MatMult(self->condensed(), self->_tmp, self->_sol);
  std::span<double> w2 = self->_work2.mutable_array();
  std::fill(w2.begin(), w2.end(), 0.0);
  PetscScalar* yy;
  VecGetArray(y, &yy);
  Blocks Y = self->blocks(yy);
  for (std::size_t i = 0; i < self->_cells.size(); ++i)
    self->_cells[i]->multiply(self->_work.array(), V.cells[i], w2, Y.cells[i]);
  self->_work2.scatter_rev(std::plus<double>());
  add_restricted(constraint, self->_work2, self->_sol);
  const PetscScalar* s;
  VecGetArrayRead(self->_sol, &s);
  std::copy(s, s + Y.u.size(), Y.u.begin());
  VecRestoreArrayRead(self->_sol, &s);
  VecRestoreArray(y, &yy);
  VecRestoreArrayRead(v, &vv);
  return 0;
}

void FbarFormulation::restore()
{
  for (auto& cells : _cells)
    cells->initialise();
}

Mat FbarFormulation::system_matrix()
{
  if (_system.constraint() and _split)
  {
    // the penalty split keeps no T^T A T: formed from the last A on each call
    _system.drop_reduced();
    _system.reduce();
  }
  return condensed();
}

Mat FbarFormulation::assemble_tangent()
{
  throw InputError("the tangent of F-bar elements is condensed inside each solve: natural "
                   "frequencies need another element (element.fbar: false, or degree 2)");
}

} // namespace muscle
