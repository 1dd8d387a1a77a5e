#include "nonlinear_solver.h"

#include "uniform_constraint.h"

#include <cmath>
#include <limits>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/la/petsc.h>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// Rigid-body modes of a 3-D displacement space, for GAMG.
MatNullSpace rigid_body_modes(const fem::FunctionSpace& V)
{
  auto map = V.dofmap()->index_map;
  const int bs = V.dofmap()->index_map_bs();
  const std::int32_t n = map->size_local();
  std::vector<la::Vector<double>> basis(6, la::Vector<double>(map, bs));
  const std::vector<double> x = V.tabulate_dof_coordinates(false);
  for (std::int32_t i = 0; i < n; ++i)
  {
    const double* p = x.data() + 3 * i;
    for (int k = 0; k < 3; ++k)
      basis[k].mutable_array()[3 * i + k] = 1;
    // rotations about e3, e1, e2
    basis[3].mutable_array()[3 * i + 0] = -p[1];
    basis[3].mutable_array()[3 * i + 1] = p[0];
    basis[4].mutable_array()[3 * i + 1] = -p[2];
    basis[4].mutable_array()[3 * i + 2] = p[1];
    basis[5].mutable_array()[3 * i + 0] = p[2];
    basis[5].mutable_array()[3 * i + 2] = -p[0];
  }
  la::orthonormalize(std::span<la::Vector<double>>(basis));
  std::vector<Vec> vecs;
  for (auto& b : basis)
    vecs.push_back(la::petsc::create_vector_wrap(b));
  MatNullSpace ns;
  MatNullSpaceCreate(map->comm(), PETSC_FALSE, 6, vecs.data(), &ns);
  for (Vec& v : vecs)
    VecDestroy(&v);
  return ns;
}
} // namespace

NonlinearSolver::NonlinearSolver(
    MuscleProblem& problem,
    std::vector<std::shared_ptr<const fem::DirichletBC<double>>> bcs,
    std::shared_ptr<const UniformDisplacementConstraint> constraint,
    NewtonOptions options)
    : NonlinearSolver(std::vector<MuscleProblem*>{&problem}, std::move(bcs),
                      std::move(constraint), std::move(options))
{
}

NonlinearSolver::NonlinearSolver(
    std::vector<MuscleProblem*> parts,
    std::vector<std::shared_ptr<const fem::DirichletBC<double>>> bcs,
    std::shared_ptr<const UniformDisplacementConstraint> constraint,
    NewtonOptions options)
    : _parts(std::move(parts)), _problem(*_parts.at(0)), _bcs(std::move(bcs)),
      _constraint(std::move(constraint)), _options(std::move(options)),
      _b(_problem.V()->dofmap()->index_map, _problem.V()->dofmap()->index_map_bs())
{
  MuscleProblem& problem = _problem;
  auto V = problem.V();
  auto map = V->dofmap()->index_map;
  const int bs = V->dofmap()->index_map_bs();
  MPI_Comm comm = map->comm();

  if (_parts.size() == 1)
    _A = fem::petsc::create_matrix(*problem.jacobian(), "aij");
  else
  {
    // every cell couples its dofs, whichever part it belongs to
    const auto& dofmap = *V->dofmap();
    la::SparsityPattern pattern = fem::create_sparsity_pattern(
        problem.mesh()->topology(), {std::cref(dofmap), std::cref(dofmap)},
        {fem::IntegralType::cell});
    pattern.assemble();
    _A = la::petsc::create_matrix(comm, pattern, "aij");
  }
  _b_petsc = la::petsc::create_vector_wrap(_b);
  VecCreateMPIWithArray(comm, 1, bs * map->size_local(), PETSC_DETERMINE,
                        _b.mutable_array().data(), &_F_full);

  SNESCreate(comm, &_snes);
  Vec F;
  Mat J = _A;
  if (_constraint)
  {
    _x = _constraint->create_reduced_vector();
    VecDuplicate(_x, &F);
    // P^T A P needs an assembled A for its symbolic phase
    update_activation();
    assemble_full_jacobian();
    MatPtAP(_A, _constraint->T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, &_A_red);
    J = _A_red;
  }
  else
  {
    // SNES owns its iterate: the line search overwrites trial states in u
    _u_petsc = la::petsc::create_vector_wrap(*problem.u()->x());
    VecDuplicate(_u_petsc, &_x);
    VecDuplicate(_b_petsc, &F);
  }
  SNESSetFunction(_snes, F, residual_callback, this);
  VecDestroy(&F);
  SNESSetJacobian(_snes, J, J, jacobian_callback, this);

  SNESSetType(_snes, SNESNEWTONLS);
  SNESSetTolerances(_snes, _options.atol, _options.rtol, 0.0,
                    _options.max_iterations, 10000);
  SNESLineSearch ls;
  SNESGetLineSearch(_snes, &ls);
  SNESLineSearchSetType(ls, _options.line_search.c_str());
  KSP ksp;
  SNESGetKSP(_snes, &ksp);
  PC pc;
  KSPGetPC(ksp, &pc);
  if (_options.linear_solver == "lu")
  {
    KSPSetType(ksp, KSPPREONLY);
    PCSetType(pc, PCLU);
    PCFactorSetMatSolverType(pc, MATSOLVERMUMPS);
  }
  else
  {
    KSPSetType(ksp, KSPGMRES);
    KSPSetTolerances(ksp, 1e-10, 1e-14, PETSC_DEFAULT, 2000);
    KSPGMRESSetRestart(ksp, 200);
    if (_options.linear_solver == "gmres-hypre")
    {
      PCSetType(pc, PCHYPRE);
      PCHYPRESetType(pc, "boomeramg");
    }
    else
    {
      PCSetType(pc, PCGAMG);
      if (!_constraint)
      {
        MatNullSpace ns = rigid_body_modes(*V);
        MatSetNearNullSpace(_A, ns);
        MatNullSpaceDestroy(&ns);
      }
      MatSetBlockSize(_A, 3);
    }
  }
  SNESSetConvergenceHistory(_snes, nullptr, nullptr, 1000, PETSC_TRUE);
  SNESSetConvergenceTest(_snes, convergence_test, this, nullptr);
  SNESSetFromOptions(_snes);
}

NonlinearSolver::~NonlinearSolver()
{
  SNESDestroy(&_snes);
  MatDestroy(&_A);
  if (_A_red)
    MatDestroy(&_A_red);
  VecDestroy(&_x);
  if (_u_petsc)
    VecDestroy(&_u_petsc);
  VecDestroy(&_b_petsc);
  VecDestroy(&_F_full);
}

Mat NonlinearSolver::system_matrix() const { return _constraint ? _A_red : _A; }

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

void NonlinearSolver::assemble_nodal_forces(la::Vector<double>& b) const
{
  std::fill(b.mutable_array().begin(), b.mutable_array().end(), 0.0);
  for (MuscleProblem* part : _parts)
    fem::assemble_vector<double>(b.mutable_array(), *part->residual());
  b.scatter_rev(std::plus<double>());
  b.scatter_fwd();
}

KernelStatus NonlinearSolver::update_activation()
{
  KernelStatus status;
  for (MuscleProblem* part : _parts)
  {
    const KernelStatus s = part->update_activation();
    if (status.failures == 0)
    {
      status.worst_cell = s.worst_cell;
      status.stretch = s.stretch;
    }
    status.failures += s.failures;
  }
  return status;
}

std::pair<double, std::int32_t> NonlinearSolver::min_jacobian_determinant() const
{
  std::pair<double, std::int32_t> worst{std::numeric_limits<double>::infinity(), -1};
  for (const MuscleProblem* part : _parts)
  {
    const auto m = part->min_jacobian_determinant();
    if (!(m.first >= worst.first))
      worst = m;
  }
  return worst;
}

PetscErrorCode NonlinearSolver::residual_callback(SNES snes, Vec x, Vec F, void* ctx)
{
  auto* self = static_cast<NonlinearSolver*>(ctx);
  self->set_state(x);
  std::span<double> b = self->_b.mutable_array();
  std::fill(b.begin(), b.end(), 0.0);
  std::span<const double> u = self->_problem.u()->x()->array();
  for (MuscleProblem* part : self->_parts)
  {
    fem::assemble_vector<double>(b, *part->residual());
    fem::apply_lifting<double>(b, {part->jacobian()}, {self->_bcs}, {u}, -1.0);
  }
  self->_b.scatter_rev(std::plus<double>());
  fem::set_bc<double>(b, self->_bcs, u, -1.0);

  if (self->_constraint)
    MatMultTranspose(self->_constraint->T(), self->_F_full, F);
  else
    VecCopy(self->_b_petsc, F);

  PetscReal norm;
  VecNorm(F, NORM_2, &norm);
  if (!std::isfinite(norm) or !self->_last_kernel.ok())
  {
    self->_non_finite = self->_non_finite or !std::isfinite(norm);
    SNESSetFunctionDomainError(snes);
  }
  return 0;
}

void NonlinearSolver::assemble_full_jacobian()
{
  Mat A = _A;
  MatZeroEntries(A);
  for (MuscleProblem* part : _parts)
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(A, ADD_VALUES), *part->jacobian(),
                         _bcs);
  MatAssemblyBegin(A, MAT_FLUSH_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FLUSH_ASSEMBLY);
  fem::set_diagonal<double>(la::petsc::Matrix::set_fn(A, INSERT_VALUES),
                            *_problem.V(), _bcs);
  MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
  MatNorm(A, NORM_INFINITY, &_matrix_norm);
}

PetscErrorCode NonlinearSolver::jacobian_callback(SNES snes, Vec x, Mat J, Mat, void* ctx)
{
  auto* self = static_cast<NonlinearSolver*>(ctx);
  self->set_state(x);
  self->assemble_full_jacobian();
  // The tangent can overflow where the residual is still finite (the coupled
  // penalty's tangent carries an extra (2 kappa)^2): report it, never solve with it
  if (!std::isfinite(self->_matrix_norm))
  {
    self->_non_finite = true;
    SNESSetJacobianDomainError(snes);
    return 0;
  }
  if (self->_constraint)
    MatPtAP(self->_A, self->_constraint->T(), MAT_REUSE_MATRIX, PETSC_DEFAULT, &J);
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
  const double floor
      = 100 * std::numeric_limits<double>::epsilon() * self->_matrix_norm * xnorm;
  if (*reason == SNES_CONVERGED_ITERATING and fnorm <= floor)
    *reason = SNES_CONVERGED_FNORM_ABS;
  if (it == 0)
    self->_norms.clear();
  self->_norms.push_back(fnorm);
  const int window = self->_options.stagnation_window;
  if (*reason == SNES_CONVERGED_ITERATING and window > 0 and it >= window
      and fnorm > (1 - self->_options.stagnation_reduction) * self->_norms[it - window])
  {
    self->_stagnated = true;
    *reason = SNES_DIVERGED_MAX_IT;
  }
  return 0;
}

NewtonReport NonlinearSolver::solve()
{
  NewtonReport report;
  _non_finite = false;
  _stagnated = false;
  if (_constraint)
    _constraint->restrict_to(*_problem.u()->x(), _x);
  else
    VecCopy(_u_petsc, _x);
  SNESSolve(_snes, nullptr, _x);
  set_state(_x); // leave u (and omega_a) at the final iterate

  SNESConvergedReason reason;
  SNESGetConvergedReason(_snes, &reason);
  report.converged = reason > 0;
  report.reason = _stagnated ? "STAGNATED (residual down by less than "
                                   + std::to_string(_options.stagnation_reduction)
                                   + " in " + std::to_string(_options.stagnation_window)
                                   + " iterations)"
                             : std::string(SNESConvergedReasons[reason]);
  PetscInt its, lits;
  SNESGetIterationNumber(_snes, &its);
  SNESGetLinearSolveIterations(_snes, &lits);
  report.iterations = its;
  report.linear_iterations = lits;
  PetscReal* history;
  PetscInt n;
  SNESGetConvergenceHistory(_snes, &history, nullptr, &n);
  report.residual_norms.assign(history, history + n);
  report.kernel = _last_kernel;
  report.non_finite = _non_finite;
  return report;
}

} // namespace muscle
