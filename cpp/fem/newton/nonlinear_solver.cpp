#include "fem/newton/nonlinear_solver.h"

#include "fem/linear/linear_failure.h"
#include "fem/linear/linear_solver.h"
#include "fem/newton/formulation.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace muscle
{
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

NonlinearSolver::NonlinearSolver(MuscleProblem& problem, DirichletBCs bcs,
                                 std::shared_ptr<const DisplacementConstraint> constraint,
                                 NewtonOptions options)
    : NonlinearSolver(std::vector<MuscleProblem*>{&problem}, std::move(bcs),
                      std::move(constraint), std::move(options))
{
}

NonlinearSolver::NonlinearSolver(std::vector<MuscleProblem*> parts, DirichletBCs bcs,
                                 std::shared_ptr<const DisplacementConstraint> constraint,
                                 NewtonOptions options)
    : _options(std::move(options)),
      _system(std::move(parts), std::move(bcs), std::move(constraint))
{
  const auto active = _petsc_options.activate();
  _options.validate();
  _formulation = make_formulation(_system, _options);
  set_up_snes();
}

NonlinearSolver::~NonlinearSolver() = default;

void NonlinearSolver::set_up_snes()
{
  SNESCreate(_system.comm(), _snes.out());
  VecHandle F;
  VecDuplicate(_formulation->iterate(), F.out());
  SNESSetFunction(_snes, F, residual_callback, this);
  Mat J = _formulation->matrix();
  SNESSetJacobian(_snes, J, J, jacobian_callback, this);
  SNESSetType(_snes, SNESNEWTONLS);
  SNESSetTolerances(_snes, _options.atol, _options.rtol, 0.0, _options.max_iterations, 10000);
  SNESLineSearch ls;
  SNESGetLineSearch(_snes, &ls);
  SNESLineSearchSetType(ls, _options.line_search.c_str());
  KSP ksp;
  SNESGetKSP(_snes, &ksp);
  _formulation->configure_linear_solver(ksp);
  SNESSetConvergenceHistory(_snes, nullptr, nullptr, 1000, PETSC_TRUE);
  SNESSetConvergenceTest(_snes, convergence_test, this, nullptr);
  SNESSetFromOptions(_snes);
  _formulation->after_options(ksp);
  PetscBool trust_region = PETSC_FALSE;
  PetscObjectTypeCompare(reinterpret_cast<PetscObject>(_snes.get()), SNESNEWTONTR,
                         &trust_region);
  if (trust_region)
    KSPSetPostSolve(ksp, trust_region_linear_check, this);
  // -ksp_type fgmres replaces GMRES after the linear solver set its restart: keep
  // the long restart unless the user gave one
  KSP linear = _formulation->linear_ksp(ksp);
  PetscBool flexible = PETSC_FALSE, restart_given = PETSC_FALSE;
  PetscObjectTypeCompare(reinterpret_cast<PetscObject>(linear), KSPFGMRES, &flexible);
  PetscOptionsHasName(nullptr, nullptr, "-ksp_gmres_restart", &restart_given);
  if (flexible and !restart_given)
    KSPGMRESSetRestart(linear, gmres_restart);
}

Mat NonlinearSolver::system_matrix() { return _formulation->system_matrix(); }

Mat NonlinearSolver::assemble_tangent() { return _formulation->assemble_tangent(); }

std::string NonlinearSolver::line_search() const
{
  PetscBool has;
  PetscObjectTypeCompare(reinterpret_cast<PetscObject>(_snes.get()), SNESNEWTONLS, &has);
  if (!has)
    return "";
  SNESLineSearch ls;
  SNESGetLineSearch(_snes, &ls);
  SNESLineSearchType type;
  SNESLineSearchGetType(ls, &type);
  return type ? type : "";
}

KSP NonlinearSolver::linear_solver() const
{
  KSP ksp;
  SNESGetKSP(_snes, &ksp);
  return _formulation->linear_ksp(ksp);
}

void NonlinearSolver::add_forms(std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> residuals,
                                std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> jacobians)
{
  _system.add_forms(std::move(residuals), std::move(jacobians));
}

void NonlinearSolver::add_term(std::shared_ptr<NonlinearTerm> term)
{
  _system.add_term(std::move(term));
}

void NonlinearSolver::assemble_nodal_forces(dolfinx::la::Vector<double>& b) const
{
  _system.assemble_nodal_forces(b);
}

KernelStatus NonlinearSolver::update_activation() { return _system.update_activation(); }

KernelStatus NonlinearSolver::restore_displacement()
{
  _system.problem().u()->x()->scatter_fwd();
  _formulation->restore();
  _last_kernel = _system.update_activation();
  return _last_kernel;
}

std::pair<double, std::int32_t> NonlinearSolver::min_jacobian_determinant() const
{
  return _system.min_jacobian_determinant();
}

void NonlinearSolver::start_clean()
{
  _non_finite = false;
  _stagnated = false;
  _crept = false;
  _test_verdict = SNES_CONVERGED_ITERATING;
  _trust_region_linear_failure = false;
  // a failed preconditioner keeps its failure, and KSPSetUp then fails every later
  // solve without applying it: a cut step starts clean (the shells' own solvers too)
  KSP outer;
  SNESGetKSP(_snes, &outer);
  clear_preconditioner_failures(outer);
  for (KSP ksp : _formulation->nested())
    clear_preconditioner_failures(ksp);
  _formulation->start_clean();
}

PetscErrorCode NonlinearSolver::solve_with_full_steps(PetscInt max_it)
{
  // the line search's type and tolerances and the SNES's own as they were (the
  // user's -snes_* and -snes_linesearch_* included: setting a type anew resets them)
  SNESLineSearch ls;
  SNESGetLineSearch(_snes, &ls);
  SNESLineSearchType type;
  SNESLineSearchGetType(ls, &type);
  const std::string previous = type;
  PetscReal steptol, maxstep, rtol, atol, ltol, snes_atol, snes_rtol, snes_stol;
  PetscInt ls_max_it, snes_max_it, max_funcs;
  SNESLineSearchGetTolerances(ls, &steptol, &maxstep, &rtol, &atol, &ltol, &ls_max_it);
  PetscInt order;
  SNESLineSearchGetOrder(ls, &order);
  SNESGetTolerances(_snes, &snes_atol, &snes_rtol, &snes_stol, &snes_max_it, &max_funcs);
  SNESLineSearchSetType(ls, SNESLINESEARCHBASIC);
  SNESSetTolerances(_snes, snes_atol, snes_rtol, snes_stol, max_it, max_funcs);
  const PetscErrorCode error = SNESSolve(_snes, nullptr, _formulation->iterate());
  SNESLineSearchSetType(ls, previous.c_str());
  SNESLineSearchSetTolerances(ls, steptol, maxstep, rtol, atol, ltol, ls_max_it);
  SNESLineSearchSetOrder(ls, order);
  SNESSetTolerances(_snes, snes_atol, snes_rtol, snes_stol, snes_max_it, max_funcs);
  return error;
}

void NonlinearSolver::first_full_step()
{
  // A formulation that keeps its Dirichlet columns (no lifting) has a moved
  // boundary value in its residual as rows u - g, which are no gradient of the
  // energy: the critical-point line search then stalls (a stiff block pulled at
  // its top: no convergence).  One full Newton step puts g in u and carries the
  // interior along; if that step leaves the admissible states, the solve starts
  // from the old state as before.
  // (a trust region, -snes_type newtontr, has no line search to stall)
  if (!(_system.boundary_change() > 0) or _options.line_search == "basic" or line_search().empty())
    return;
  Vec x = _formulation->iterate();
  VecHandle start;
  VecDuplicate(x, start.out());
  VecCopy(x, start);
  const PetscErrorCode error = solve_with_full_steps(1);
  SNESConvergedReason reason;
  SNESGetConvergedReason(_snes, &reason);
  // a failed linear solve took no step; its failure must not fail the solve after it
  if (error or reason == SNES_DIVERGED_FUNCTION_DOMAIN or reason == SNES_DIVERGED_LINEAR_SOLVE
      or _non_finite)
    VecCopy(start, x);
  else
    _full_steps = 1;
  start_clean();
}

bool NonlinearSolver::zero_update() const
{
  Vec dx;
  PetscReal norm = 0;
  SNESGetSolutionUpdate(_snes, &dx);
  return dx and !VecNorm(dx, NORM_2, &norm) and !(norm > 0);
}

bool NonlinearSolver::stopped_short_of_constraint() const
{
  SNESConvergedReason reason;
  SNESGetConvergedReason(_snes, &reason);
  return reason > 0 and _test_verdict <= 0 and !line_search().empty()
         and !(_formulation->constraint_violation() <= _options.fbar_constraint_tolerance)
         and !zero_update();
}

bool NonlinearSolver::creeping() const
{
  const int window = _options.creep_window;
  if (window <= 0 or static_cast<int>(_step_lengths.size()) < window
      or line_search() != SNESLINESEARCHCP)
    return false;
  return std::all_of(_step_lengths.end() - window, _step_lengths.end(),
                     [this](double lambda) { return lambda < _options.creep_step; });
}

NewtonReport NonlinearSolver::solve()
{
  const auto active = _petsc_options.activate();
  start_clean();
  _step_lengths.clear();
  _full_steps = 0;
  const long inner_before = _formulation->inner_iterations();
  // a PETSc error inside the solve (SOR's "Zero diagonal", a failed
  // factorisation) fails this solve with PETSc's message: the stepper cuts the
  // step and, in the end, stops with advice -- no trace on the console
  PetscErrorCode error = 0;
  std::optional<QuietPetscErrors> quiet(std::in_place);
  _formulation->start();
  Vec x = _formulation->iterate();
  if (_formulation->keeps_dirichlet_rows())
    first_full_step();
  error = SNESSolve(_snes, nullptr, x);
  if (!error and stopped_short_of_constraint())
  {
    // cp stops where dot(F, dx) is below its atol, and a constraint's rows can be
    // tiny in that product (F-bar's theta): it can stop with the residual at
    // round-off and the constraint unmet, a state the convergence test refused.
    // Newton's full step closes the constraint.
    PetscInt its, max_it;
    SNESGetIterationNumber(_snes, &its);
    SNESGetTolerances(_snes, nullptr, nullptr, nullptr, &max_it, nullptr);
    _full_steps += its;
    _test_verdict = SNES_CONVERGED_ITERATING;
    error = solve_with_full_steps(std::max<PetscInt>(1, max_it - _full_steps));
  }
  _last_kernel = _formulation->set_state(x); // leave the fields at the final iterate
  quiet.reset();
  NewtonReport report = outcome(error, inner_before);
  if (report.converged)
    _formulation->converged();
  return report;
}

} // namespace muscle
