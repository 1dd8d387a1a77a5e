#include "nonlinear_solver.h"
#include "linear_failure.h"
#include "../common/errors.h"

#include "fbar_unknowns.h"
#include "constraint.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/la/petsc.h>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// Rigid-body modes of a 3-D displacement space, for GAMG: on V's unknowns, or,
/// under a constraint, restricted to the reduced unknowns (the uniform-axial
/// set takes the mode's mean; a tie keeps the master's values).  Without them
/// GAMG coarsens the free muscle's system as a scalar problem (BENCHMARKS.md).
MatNullSpace rigid_body_modes(const fem::FunctionSpace& V,
                              const DisplacementConstraint* constraint)
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
  // PETSc-owned copies: the null space outlives `basis` (a wrapped array would
  // dangle, and GAMG would coarsen with whatever reuses that memory)
  std::vector<Vec> vecs;
  for (auto& b : basis)
  {
    Vec copy;
    if (constraint)
    {
      b.scatter_fwd();
      copy = constraint->create_reduced_vector();
      constraint->restrict_to(b, copy);
    }
    else
    {
      Vec wrap = la::petsc::create_vector_wrap(b);
      VecDuplicate(wrap, &copy);
      VecCopy(wrap, copy);
      VecDestroy(&wrap);
    }
    vecs.push_back(copy);
  }
  // PETSc asks for an orthonormal basis: Gram-Schmidt, twice for round-off
  for (std::size_t i = 0; i < vecs.size(); ++i)
    for (int pass = 0; pass < 2; ++pass)
    {
      for (std::size_t j = 0; j < i; ++j)
      {
        PetscScalar d;
        VecDot(vecs[i], vecs[j], &d);
        VecAXPY(vecs[i], -d, vecs[j]);
      }
      VecNormalize(vecs[i], nullptr);
    }
  MatNullSpace ns;
  MatNullSpaceCreate(map->comm(), PETSC_FALSE, 6, vecs.data(), &ns);
  for (Vec& v : vecs)
    VecDestroy(&v);
  return ns;
}

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

const std::vector<std::string>& NewtonOptions::linear_solvers()
{
  static const std::vector<std::string> names = {"lu", "gmres-hypre", "gmres-gamg"};
  return names;
}

const std::vector<std::string>& NewtonOptions::line_searches()
{
  static const std::vector<std::string> names = {"cp", "bt", "basic", "l2"};
  return names;
}

void NewtonOptions::validate() const
{
  auto check = [](const char* option, const std::string& value,
                  const std::vector<std::string>& allowed)
  {
    if (std::find(allowed.begin(), allowed.end(), value) == allowed.end())
      throw InputError(std::string(option) + " '" + value + "' is not allowed; allowed: "
                       + join(allowed) + did_you_mean(value, allowed));
  };
  check("linear solver", linear_solver, linear_solvers());
  check("line search", line_search, line_searches());
  if (!(rtol > 0 and atol > 0 and linear_rtol > 0 and linear_rtol < 1))
    throw InputError("Newton tolerances must be > 0 and the linear rtol below 1");
}

NonlinearSolver::NonlinearSolver(
    MuscleProblem& problem,
    std::vector<std::shared_ptr<const fem::DirichletBC<double>>> bcs,
    std::shared_ptr<const DisplacementConstraint> constraint,
    NewtonOptions options)
    : NonlinearSolver(std::vector<MuscleProblem*>{&problem}, std::move(bcs),
                      std::move(constraint), std::move(options))
{
}

NonlinearSolver::NonlinearSolver(
    std::vector<MuscleProblem*> parts,
    std::vector<std::shared_ptr<const fem::DirichletBC<double>>> bcs,
    std::shared_ptr<const DisplacementConstraint> constraint,
    NewtonOptions options)
    : _parts(std::move(parts)), _problem(*_parts.at(0)), _bcs(std::move(bcs)),
      _constraint(std::move(constraint)), _options(std::move(options)),
      _b(_problem.V()->dofmap()->index_map, _problem.V()->dofmap()->index_map_bs()),
      _work(_b), _work2(_b)
{
  _options.validate();
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
  const bool three_field
      = _options.fbar_cell_unknowns
        and std::all_of(_parts.begin(), _parts.end(), [](auto* p) { return p->fbar(); });
  if (_constraint)
  {
    _x = _constraint->create_reduced_vector();
    VecDuplicate(_x, &F);
  }
  else
  {
    // SNES owns its iterate: the line search overwrites trial states in u
    _u_petsc = la::petsc::create_vector_wrap(*problem.u()->x());
    VecDuplicate(_u_petsc, &_x);
    VecDuplicate(_b_petsc, &F);
  }
  if (three_field)
  {
    VecDestroy(&F);
    create_cell_unknowns();
    VecDuplicate(_x_ext, &F);
    J = _J_ext;
  }
  else if (_constraint)
  {
    // P^T A P needs an assembled A for its symbolic phase
    update_activation();
    assemble_full_jacobian();
    reduce(nullptr, true);
    J = _A_red;
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
  // three-field: the linear solver works on the condensed displacement system
  KSP linear = three_field ? _inner : ksp;
  PC pc;
  KSPGetPC(linear, &pc);
  if (_options.linear_solver == "lu")
  {
    KSPSetType(linear, KSPPREONLY);
    PCSetType(pc, PCLU);
    PCFactorSetMatSolverType(pc, MATSOLVERMUMPS);
  }
  else
  {
    KSPSetType(linear, KSPGMRES);
    KSPSetTolerances(linear, _options.linear_rtol, 1e-14, PETSC_DEFAULT, 2000);
    KSPGMRESSetRestart(linear, 200);
    if (_options.linear_solver == "gmres-hypre")
    {
      PCSetType(pc, PCHYPRE);
      PCHYPRESetType(pc, "boomeramg");
    }
    else
    {
      PCSetType(pc, PCGAMG);
      _near_null_space = rigid_body_modes(*V, _constraint.get());
      if (!_constraint)
        MatSetNearNullSpace(_A, _near_null_space);
      else if (_A_red)
        MatSetNearNullSpace(_A_red, _near_null_space);
      MatSetBlockSize(_A, 3);
    }
  }
  SNESSetConvergenceHistory(_snes, nullptr, nullptr, 1000, PETSC_TRUE);
  SNESSetConvergenceTest(_snes, convergence_test, this, nullptr);
  SNESSetFromOptions(_snes);
  if (three_field)
  {
    // PETSc's -ksp_* and -pc_* options configure the condensed solve; the SNES's
    // own KSP only eliminates and recovers the cell unknowns around it
    KSPSetFromOptions(_inner);
    KSPSetType(ksp, KSPPREONLY);
    KSPGetPC(ksp, &pc);
    PCSetType(pc, PCSHELL);
    PCShellSetContext(pc, this);
    PCShellSetApply(pc, condensed_solve);
    PCShellSetName(pc, "F-bar cell unknowns eliminated around the condensed solve");
  }
}

NonlinearSolver::~NonlinearSolver()
{
  SNESDestroy(&_snes);
  KSPDestroy(&_inner);
  MatDestroy(&_J_ext);
  for (Vec* v : {&_x_ext, &_rhs, &_sol, &_tmp})
    VecDestroy(v);
  MatDestroy(&_A);
  if (_A_red)
    MatDestroy(&_A_red);
  if (_ptap)
    MatDestroy(&_ptap);
  if (_near_null_space)
    MatNullSpaceDestroy(&_near_null_space);
  VecDestroy(&_x);
  if (_u_petsc)
    VecDestroy(&_u_petsc);
  VecDestroy(&_b_petsc);
  if (_term_F)
    VecDestroy(&_term_F);
  VecDestroy(&_F_full);
}

Mat NonlinearSolver::system_matrix() const { return _constraint ? _A_red : _A; }

KSP NonlinearSolver::linear_solver() const
{
  if (_inner)
    return _inner;
  KSP ksp;
  SNESGetKSP(_snes, &ksp);
  return ksp;
}

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

void NonlinearSolver::add_forms(std::vector<std::shared_ptr<const fem::Form<double>>> residuals,
                                std::vector<std::shared_ptr<const fem::Form<double>>> jacobians)
{
  _extra_residuals.insert(_extra_residuals.end(), residuals.begin(), residuals.end());
  _extra_jacobians.insert(_extra_jacobians.end(), jacobians.begin(), jacobians.end());
}

void NonlinearSolver::add_term(std::shared_ptr<NonlinearTerm> term)
{
  if (!_term_F)
  {
    VecDuplicate(_b_petsc, &_term_F);
    VecSetOption(_term_F, VEC_IGNORE_NEGATIVE_INDICES, PETSC_TRUE); // fixed dofs
    MatSetOption(_A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
    if (_A_red)
      MatSetOption(_A_red, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
  }
  _terms.push_back(std::move(term));
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

void NonlinearSolver::reduce(Mat J, bool first)
{
  PetscObjectState state;
  MatGetNonzeroState(_A, &state);
  // the state is a rank's own: one rank's new contact nonzeros must send every
  // rank down the same (collective) branch
  int changed = state != _reduced_state;
  MPI_Allreduce(MPI_IN_PLACE, &changed, 1, MPI_INT, MPI_MAX, _problem.mesh()->comm());
  if (first)
    MatPtAP(_A, _constraint->T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, &_A_red);
  else if (changed)
  {
    // A gained nonzeros (contact): a new product of our own, copied into J (which
    // the KSP holds).  J's own product data describe the old pattern, so J is
    // never recomputed in place again: a numeric PtAP on a stale symbolic
    // product reads past its arrays (crashed on 2 ranks).
    if (_ptap)
      MatDestroy(&_ptap);
    MatPtAP(_A, _constraint->T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, &_ptap);
    MatSetOption(J, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
    MatCopy(_ptap, J, DIFFERENT_NONZERO_PATTERN);
  }
  else if (_ptap)
  {
    MatPtAP(_A, _constraint->T(), MAT_REUSE_MATRIX, PETSC_DEFAULT, &_ptap);
    MatCopy(_ptap, J, SAME_NONZERO_PATTERN);
  }
  else
    MatPtAP(_A, _constraint->T(), MAT_REUSE_MATRIX, PETSC_DEFAULT, &J);
  _reduced_state = state;
}

void NonlinearSolver::assemble_nodal_forces(la::Vector<double>& b) const
{
  std::fill(b.mutable_array().begin(), b.mutable_array().end(), 0.0);
  for (MuscleProblem* part : _parts)
    fem::assemble_vector<double>(b.mutable_array(), *part->residual());
  for (const auto& r : _extra_residuals)
    fem::assemble_vector<double>(b.mutable_array(), *r);
  b.scatter_rev(std::plus<double>());
  add_term_residuals(b.mutable_array());
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
  // every rank must take the same path through SNES (domain errors)
  MPI_Allreduce(MPI_IN_PLACE, &status.failures, 1, MPI_INT, MPI_SUM,
                _problem.mesh()->comm());
  return status;
}

KernelStatus NonlinearSolver::restore_displacement()
{
  _problem.u()->x()->scatter_fwd();
  for (auto& cells : _cell_unknowns)
    cells->initialise();
  _last_kernel = update_activation();
  return _last_kernel;
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
  if (!self->_cell_unknowns.empty())
  {
    self->set_extended_state(x);
    self->extended_residual(F);
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
  self->set_state(x);
  std::span<double> b = self->_b.mutable_array();
  std::fill(b.begin(), b.end(), 0.0);
  std::span<const double> u = self->_problem.u()->x()->array();
  for (MuscleProblem* part : self->_parts)
  {
    fem::assemble_vector<double>(b, *part->residual());
    fem::apply_lifting<double>(b, {part->jacobian()}, {self->_bcs}, {u}, -1.0);
  }
  for (const auto& r : self->_extra_residuals)
    fem::assemble_vector<double>(b, *r);
  for (const auto& J : self->_extra_jacobians)
    fem::apply_lifting<double>(b, {J}, {self->_bcs}, {u}, -1.0);
  self->_b.scatter_rev(std::plus<double>());
  self->add_term_residuals(b);
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
  for (const auto& J : _extra_jacobians)
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(A, ADD_VALUES), *J, _bcs);
  for (const auto& t : _terms)
    t->add_jacobian(A);
  MatAssemblyBegin(A, MAT_FLUSH_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FLUSH_ASSEMBLY);
  fem::set_diagonal<double>(la::petsc::Matrix::set_fn(A, INSERT_VALUES),
                            *_problem.V(), _bcs);
  MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
  _matrix_norm = finite_norm(A);
}

PetscErrorCode NonlinearSolver::jacobian_callback(SNES snes, Vec x, Mat J, Mat, void* ctx)
{
  auto* self = static_cast<NonlinearSolver*>(ctx);
  if (!self->_cell_unknowns.empty())
  {
    self->set_extended_state(x);
    self->assemble_three_field_jacobian();
    if (!std::isfinite(self->_matrix_norm))
    {
      self->_non_finite = true;
      SNESSetJacobianDomainError(snes);
    }
    return 0;
  }
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
  // (three-field: |x| of the displacement block only -- theta and p have other units)
  const double floor = 100 * std::numeric_limits<double>::epsilon() * self->_matrix_norm
                       * (self->_cell_unknowns.empty() ? xnorm : self->displacement_norm(snes));
  if (*reason == SNES_CONVERGED_ITERATING and std::isfinite(floor) and fnorm <= floor)
    *reason = SNES_CONVERGED_FNORM_ABS;
  // three-field: converged only once theta = J0(u) too (R_p is tiny in the norm)
  if (*reason > 0 and !self->_cell_unknowns.empty()
      and !(self->_constraint_violation <= self->_options.fbar_constraint_tolerance))
    *reason = SNES_CONVERGED_ITERATING;
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

namespace
{
/// PETSc errors return their code instead of printing a trace, for a scope
/// (exception-safe: a callback may throw through SNESSolve).
struct QuietPetscErrors
{
  QuietPetscErrors() { PetscPushErrorHandler(PetscReturnErrorHandler, nullptr); }
  ~QuietPetscErrors() { PetscPopErrorHandler(); }
  QuietPetscErrors(const QuietPetscErrors&) = delete;
  QuietPetscErrors& operator=(const QuietPetscErrors&) = delete;
};
} // namespace

NewtonReport NonlinearSolver::solve()
{
  NewtonReport report;
  _non_finite = false;
  _stagnated = false;
  if (_constraint)
    _constraint->restrict_to(*_problem.u()->x(), _x);
  else
    VecCopy(_u_petsc, _x);
  const long inner_before = _inner_iterations;
  _linear_error = 0;
  // a PETSc error inside the solve (SOR's "Zero diagonal", a failed
  // factorisation) fails this solve with PETSc's message: the stepper cuts the
  // step and, in the end, stops with advice -- no trace on the console
  PetscErrorCode error = 0;
  std::optional<QuietPetscErrors> quiet(std::in_place);
  if (!_cell_unknowns.empty())
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
    error = SNESSolve(_snes, nullptr, _x_ext);
    set_extended_state(_x_ext);
  }
  else
  {
    error = SNESSolve(_snes, nullptr, _x);
    set_state(_x); // leave u (and omega_a) at the final iterate
  }

  quiet.reset();
  SNESConvergedReason reason;
  SNESGetConvergedReason(_snes, &reason);
  if (error and reason > 0)
    reason = SNES_DIVERGED_FUNCTION_DOMAIN; // never report an errored solve as converged
  report.converged = reason > 0 and !error;
  report.reason = _stagnated ? "STAGNATED (residual down by less than "
                                   + std::to_string(_options.stagnation_reduction)
                                   + " in " + std::to_string(_options.stagnation_window)
                                   + " iterations)"
                             : std::string(SNESConvergedReasons[reason]);
  if (error)
  {
    // in the displacement Newton the error escapes SNES from its KSP
    report.reason = "DIVERGED_LINEAR_SOLVE";
    report.linear_failure = describe_linear_failure(linear_solver(), error);
  }
  else if (reason == SNES_DIVERGED_LINEAR_SOLVE)
    report.linear_failure = describe_linear_failure(linear_solver(), _linear_error);
  if (!report.linear_failure.empty())
    report.reason += " (" + report.linear_failure + ")";
  if (!report.converged)
    for (const auto& t : _terms)
      if (const std::string d = t->diagnosis(); !d.empty())
        report.reason += "; " + d;
  PetscInt its, lits;
  SNESGetIterationNumber(_snes, &its);
  SNESGetLinearSolveIterations(_snes, &lits);
  report.iterations = its + _full_steps;
  report.linear_iterations = _cell_unknowns.empty() ? lits : _inner_iterations - inner_before;
  PetscReal* history;
  PetscInt n;
  SNESGetConvergenceHistory(_snes, &history, nullptr, &n);
  report.residual_norms.assign(history, history + n);
  report.kernel = _last_kernel;
  report.non_finite = _non_finite;
  return report;
}

// ---------------------------------------------------------------------------
// Three-field F-bar: the SNES vector is [u part | cells of part 0 | ...]
// ---------------------------------------------------------------------------

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
  if (!(moved > 0) or _options.line_search == "basic")
    return;
  Vec start;
  VecDuplicate(_x_ext, &start);
  VecCopy(_x_ext, start);
  SNESLineSearch ls;
  SNESGetLineSearch(_snes, &ls);
  SNESLineSearchType type;
  SNESLineSearchGetType(ls, &type);
  const std::string previous = type;
  SNESLineSearchSetType(ls, SNESLINESEARCHBASIC);
  SNESSetTolerances(_snes, _options.atol, _options.rtol, 0.0, 1, 10000);
  const PetscErrorCode error = SNESSolve(_snes, nullptr, _x_ext);
  SNESConvergedReason reason;
  SNESGetConvergedReason(_snes, &reason);
  SNESLineSearchSetType(ls, previous.c_str());
  SNESSetTolerances(_snes, _options.atol, _options.rtol, 0.0, _options.max_iterations, 10000);
  if (error or reason == SNES_DIVERGED_FUNCTION_DOMAIN or _non_finite)
  {
    VecCopy(start, _x_ext);
    _non_finite = false;
  }
  else
    _full_steps = 1;
  VecDestroy(&start);
}

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
  if (_constraint)
  {
    // P^T A P needs an assembled A for its symbolic phase
    _problem.u()->x()->scatter_fwd();
    for (auto& cells : _cell_unknowns)
      cells->initialise();
    assemble_three_field_jacobian();
  }
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

void NonlinearSolver::to_full(Vec du)
{
  if (_constraint)
    _constraint->prolong(du, _work);
  else
  {
    const PetscScalar* a;
    VecGetArrayRead(du, &a);
    PetscInt n;
    VecGetLocalSize(du, &n);
    std::copy(a, a + n, _work.mutable_array().begin());
    VecRestoreArrayRead(du, &a);
    _work.scatter_fwd();
  }
}

void NonlinearSolver::add_restricted(const la::Vector<double>& w, Vec x)
{
  PetscInt n;
  VecGetLocalSize(x, &n);
  if (_constraint)
  {
    Vec wv;
    const auto map = w.map();
    VecCreateMPIWithArray(map->comm(), 1, w.bs() * map->size_local(), PETSC_DETERMINE,
                          w.array().data(), &wv);
    MatMultTransposeAdd(_constraint->T(), wv, x, x);
    VecDestroy(&wv);
  }
  else
  {
    PetscScalar* a;
    VecGetArray(x, &a);
    for (PetscInt i = 0; i < n; ++i)
      a[i] += w.array()[i];
    VecRestoreArray(x, &a);
  }
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
  for (const auto& J : _extra_jacobians)
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(_A, ADD_VALUES), *J, _bcs);
  for (const auto& t : _terms)
    t->add_jacobian(_A);
  MatAssemblyBegin(_A, MAT_FLUSH_ASSEMBLY);
  MatAssemblyEnd(_A, MAT_FLUSH_ASSEMBLY);
  fem::set_diagonal<double>(la::petsc::Matrix::set_fn(_A, INSERT_VALUES), *_problem.V(),
                            _bcs);
  MatAssemblyBegin(_A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_A, MAT_FINAL_ASSEMBLY);
  _matrix_norm = finite_norm(_A);
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
  if (_constraint)
  {
    const bool first = !_A_red;
    reduce(_A_red, first);
    if (first and _near_null_space)
      MatSetNearNullSpace(_A_red, _near_null_space);
    K = _A_red;
  }
  KSPSetOperators(_inner, K, K);
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

PetscErrorCode NonlinearSolver::condensed_solve(PC pc, Vec b_ext, Vec y_ext)
{
  NonlinearSolver* self;
  PCShellGetContext(pc, &self);
  // PETSc keeps a shell PC's failure until it is cleared: one failed inner
  // solve would otherwise fail every later Newton step (and every cutback)
  PCSetFailedReason(pc, PC_NOERROR);
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
  const PetscErrorCode error = KSPSolve(self->_inner, self->_rhs, self->_sol);
  PetscPopErrorHandler();
  PetscInt its = 0;
  KSPGetIterationNumber(self->_inner, &its);
  self->_inner_iterations += its;
  KSPConvergedReason reason = KSP_DIVERGED_PC_FAILED;
  self->_linear_error = error;
  if (!error)
    KSPGetConvergedReason(self->_inner, &reason);
  if (reason < 0)
  {
    PCSetFailedReason(pc, PC_SUBPC_ERROR);
    VecSet(y_ext, 0.0);
    VecRestoreArrayRead(b_ext, &bb);
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
  MatMult(self->_constraint ? self->_A_red : self->_A, self->_tmp, self->_sol);
  self->to_full(self->_tmp);
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
