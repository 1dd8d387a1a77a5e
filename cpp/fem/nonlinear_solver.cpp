#include "nonlinear_solver.h"

#include "../common/errors.h"
#include "../common/petsc_options.h"
#include "augmented_lagrangian.h"
#include "constraint.h"
#include "fbar_unknowns.h"
#include "linear_failure.h"
#include "p_multigrid.h"
#include "rigid_body_modes.h"
#include "star_relaxation.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/la/petsc.h>
#include <limits>
#include <optional>

using namespace dolfinx;

namespace muscle
{
namespace
{
// a restart throws the Krylov space away and slows the convergence
constexpr PetscInt gmres_restart = 200;

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
  expand_stars(_problem.taylor_hood());
  refuse_unread_options(_problem.taylor_hood(),
                        _options.fbar_cell_unknowns
                            and std::all_of(_parts.begin(), _parts.end(),
                                            [](auto* p) { return p->fbar(); }));
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
  if (_constraint and _options.linear_solver == "gmres-gamg" and _options.reduced_blocks
      and _constraint->keeps_whole_nodes())
    _reduced_bs = bs;
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
  const bool taylor_hood = _problem.taylor_hood();
  read_al_gamma(taylor_hood and !three_field);
  if (three_field)
  {
    VecDestroy(&F);
    create_cell_unknowns();
    VecDuplicate(_x_ext, &F);
    J = _J_ext;
  }
  else if (taylor_hood)
  {
    VecDestroy(&F);
    create_pressure_unknowns();
    VecDuplicate(_x_ext, &F);
    J = _J_mixed ? _J_mixed : _J_nest; // the nest under GMRES
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
  configure_linear_solver(three_field ? _inner : ksp);
  SNESSetConvergenceHistory(_snes, nullptr, nullptr, 1000, PETSC_TRUE);
  SNESSetConvergenceTest(_snes, convergence_test, this, nullptr);
  SNESSetFromOptions(_snes);
  if (three_field)
  {
    // PETSc's -ksp_* and -pc_* options configure the condensed solve; the SNES's
    // own KSP only eliminates and recovers the cell unknowns around it
    KSPSetFromOptions(_inner);
    KSPSetType(ksp, KSPPREONLY);
    PC pc;
    KSPGetPC(ksp, &pc);
    PCSetType(pc, PCSHELL);
    PCShellSetContext(pc, this);
    PCShellSetApply(pc, condensed_solve);
    PCShellSetName(pc, "F-bar cell unknowns eliminated around the condensed solve");
  }
  PetscBool trust_region = PETSC_FALSE;
  PetscObjectTypeCompare(reinterpret_cast<PetscObject>(_snes), SNESNEWTONTR, &trust_region);
  if (trust_region)
    KSPSetPostSolve(ksp, trust_region_linear_check, this);
  // -ksp_type fgmres replaces GMRES after configure_linear_solver set its restart:
  // keep the long restart unless the user gave one
  KSP linear = three_field ? _inner : ksp;
  PetscBool flexible = PETSC_FALSE, restart_given = PETSC_FALSE;
  PetscObjectTypeCompare(reinterpret_cast<PetscObject>(linear), KSPFGMRES, &flexible);
  PetscOptionsHasName(nullptr, nullptr, "-ksp_gmres_restart", &restart_given);
  if (flexible and !restart_given)
    KSPGMRESSetRestart(linear, gmres_restart);
}

void NonlinearSolver::refuse_unread_options(bool taylor_hood, bool three_field) const
{
  // PETSc's unused-option warning is off in our runs: the user would believe the
  // option acted (p-multigrid: configure_mixed_shell)
  const bool pmg = taylor_hood and !three_field and _options.linear_solver == "gmres-schur"
                   and string_option("-fieldsplit_u_pc_type") == "mg";
  const bool stars = pmg and string_option("-fieldsplit_u_mg_levels_pc_type") == PCSTARS;
  const std::pair<const char*, bool> ours[] = {{"-fieldsplit_u_mg_coarse_lag", pmg},
                                               {"-fieldsplit_u_mg_levels_pc_stars_double", stars}};
  for (const auto& [name, read] : ours)
  {
    PetscBool given = PETSC_FALSE;
    PetscOptionsHasName(nullptr, nullptr, name, &given);
    if (given and !read)
      throw InputError(std::string(name) + ": an option of p-multigrid on Taylor-Hood's "
                       "displacement block (linear: gmres-schur, -fieldsplit_u_pc_type mg"
                       + (name == ours[1].first ? " with -fieldsplit_u_mg_levels_pc_type stars"
                                                : "")
                       + "), which this run does not use; leave it out");
  }
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

void NonlinearSolver::expand_stars(bool taylor_hood)
{
  if (_options.linear_solver != "gmres-stars")
    return;
  if (!taylor_hood)
    throw InputError("linear solver gmres-stars: the Taylor-Hood field split relaxed on "
                     "vertex stars, for element.taylor_hood: true (--taylor-hood) only; "
                     "this run's element has no pressure unknowns (for F-bar: gmres-schur)");
  // the kappa candidate "..., stars, BoomerAMG, lag 2": flat in kappa and 1.2-1.4x per
  // refinement on the fusiform, the one split that runs its free contraction at n = 2
  // (BENCHMARKS.md, "Preconditioners against kappa")
  set_unless_given({{"-al_gamma", "1"}, {"-fieldsplit_u_pc_type", "mg"}});
  // the multigrid's own options only under it: refuse_unread_options would blame the
  // user for options the preset set
  if (string_option("-fieldsplit_u_pc_type") == "mg")
    set_unless_given({{"-fieldsplit_u_mg_levels_pc_type", PCSTARS},
                      {"-fieldsplit_u_mg_coarse_pc_type", "hypre"},
                      {"-fieldsplit_u_mg_coarse_lag", "2"}});
  // the q block's Schur approximation, the degree-1 mass matrix in a 2 x 2 pattern per
  // node, by eight Chebyshev steps on Jacobi of the node blocks in place of MUMPS's
  // factor, which grows faster than the unknowns.  Jacobi keeps a constant node block
  // times a trilinear mass matrix on parallelepipeds in [1/8, 27/8] (Wathen; linear
  // tetrahedra [1/2, 5/2]); the bounds hold on the fusiform's curved cells and varying
  // blocks by measurement, and fixed bounds and steps make a fixed linear
  // preconditioner.  Counts within 11 % of MUMPS's, less memory and time
  // (BENCHMARKS.md, "Preconditioners against kappa").  All or nothing: a q solver or
  // factor the user chose is left alone, with the factor that is the split's default
  if (string_option("-fieldsplit_q_ksp_type").empty()
      and string_option("-fieldsplit_q_pc_type").empty() and !factor_options_given("fieldsplit_q_"))
    set_unless_given({{"-fieldsplit_q_ksp_type", "chebyshev"},
                      {"-fieldsplit_q_ksp_max_it", "8"},
                      {"-fieldsplit_q_ksp_norm_type", "none"},
                      {"-fieldsplit_q_pc_type", "pbjacobi"},
                      {"-fieldsplit_q_ksp_chebyshev_eigenvalues", "0.12,3.4"}});
  _options.linear_solver = "gmres-schur";
}

void NonlinearSolver::read_al_gamma(bool taylor_hood)
{
  PetscBool given = PETSC_FALSE;
  PetscOptionsHasName(nullptr, nullptr, "-al_gamma", &given);
  // a Taylor-Hood run with a solver it cannot use: create_pressure_unknowns says so
  const std::string& solver = _options.linear_solver;
  if (!given or (taylor_hood and solver != "lu" and solver != "gmres-schur"))
    return;
  // PETSc would ignore -al_gamma elsewhere without a word (its unused-option warning
  // is off in our runs), and the user would believe the run augmented
  if (!(taylor_hood and solver == "gmres-schur"))
    throw InputError(std::string("-al_gamma: the augmented-Lagrangian form of the Taylor-Hood "
                                 "split, for element.taylor_hood: true with linear: "
                                 "gmres-schur only; this run has ")
                     + (taylor_hood ? "" : "element.taylor_hood: false, ") + "linear: " + solver);
  const std::string text = string_option("-al_gamma");
  char* end = nullptr;
  _al_gamma = std::strtod(text.c_str(), &end);
  if (text.empty() or *end != '\0' or !(_al_gamma > 0) or !std::isfinite(_al_gamma))
    throw InputError("-al_gamma '" + text
                     + "': the augmented Lagrangian's penalty over the law's shear "
                       "modulus at rest must be a number > 0 (1 is a good start); leave "
                       "the option out for the plain Schur split");
}

void NonlinearSolver::configure_linear_solver(KSP linear)
{
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
    KSPGMRESSetRestart(linear, gmres_restart);
    if (_options.linear_solver == "gmres-schur" and _taylor_hood)
    {
      configure_mixed_split(pc);
      KSPSetPCSide(linear, PC_RIGHT);
    }
    else if (_options.linear_solver == "gmres-schur")
    {
      if (!_inner)
        throw InputError("linear solver gmres-schur: only for F-bar elements with the "
                         "three-field Newton (element.fbar: true, cell unknowns on) and for "
                         "Taylor-Hood elements (element.taylor_hood: true)");
      _near_null_space = rigid_body_modes(*_problem.V(), _constraint.get(),
                                          _options.near_null_space == "bodies");
      create_penalty_split(_problem.mesh()->comm());
      PCSetType(pc, PCSHELL);
      PCShellSetContext(pc, this);
      PCShellSetApply(pc, penalty_split_apply);
      PCShellSetName(pc, "penalty split: V-cycles on the soft matrix, diagonal Schur");
      // the residual GMRES tests is the true one (the saddle form's q rows included)
      KSPSetPCSide(linear, PC_RIGHT);
    }
    else if (_options.linear_solver == "gmres-hypre")
    {
      PCSetType(pc, PCHYPRE);
      PCHYPRESetType(pc, "boomeramg");
    }
    else
    {
      PCSetType(pc, PCGAMG);
      _near_null_space = rigid_body_modes(*_problem.V(), _constraint.get(),
                                          _options.near_null_space == "bodies");
      if (!_constraint)
        MatSetNearNullSpace(_A, _near_null_space);
      else if (_A_red)
        MatSetNearNullSpace(_A_red, _near_null_space);
      MatSetBlockSize(_A, 3);
    }
  }
}

NonlinearSolver::~NonlinearSolver()
{
  SNESDestroy(&_snes);
  KSPDestroy(&_inner);
  KSPDestroy(&_soft);
  KSPDestroy(&_schur);
  MatDestroy(&_schur_factor);
  MatDestroy(&_schur_sym);
  MatDestroy(&_A_soft);
  MatDestroy(&_A_soft_red);
  MatDestroy(&_saddle);
  for (Vec* v : {&_soft_r, &_saddle_b, &_saddle_x, &_part_in, &_part_out, &_schur_rhs, &_schur_w})
    VecDestroy(v);
  MatDestroy(&_J_ext);
  for (Mat& M : _th_blocks)
    MatDestroy(&M);
  for (Mat& M : _th_reduced)
    MatDestroy(&M);
  MatDestroy(&_J_nest);
  MatDestroy(&_schur_pre);
  KSPDestroy(&_u_ksp);
  KSPDestroy(&_q_ksp);
  for (Vec* v : {&_mix_u_in, &_mix_u_out, &_mix_q_in, &_mix_q_out, &_mix_u_rhs})
    VecDestroy(v);
  MatDestroy(&_J_mixed);
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
  VecDestroy(&_full_tmp);
}

Mat NonlinearSolver::system_matrix()
{
  if (_constraint and _soft)
  {
    // the penalty split keeps no T^T A T: formed from the last A on each call
    MatDestroy(&_A_red);
    MatDestroy(&_ptap);
    reduce(nullptr, true);
  }
  return _constraint ? _A_red : _A;
}

Mat NonlinearSolver::assemble_tangent()
{
  if (!_cell_unknowns.empty())
    throw InputError("the tangent of F-bar elements is condensed inside each solve: natural "
                     "frequencies need another element (element.fbar: false, or degree 2)");
  if (_taylor_hood)
    throw InputError("the tangent of Taylor-Hood elements holds the pressure: natural "
                     "frequencies need a displacement element (element.taylor_hood: false)");
  _last_kernel = update_activation();
  assemble_full_jacobian();
  return _A;
}

std::string NonlinearSolver::line_search() const
{
  PetscBool has;
  PetscObjectTypeCompare(reinterpret_cast<PetscObject>(_snes), SNESNEWTONLS, &has);
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
  if (_inner)
    return _inner;
  KSP ksp;
  SNESGetKSP(_snes, &ksp);
  return ksp;
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
  if (_taylor_hood)
  {
    // the restored u is the last converged state's (a cut step): so is its q
    auto q = _problem.th_state()->x();
    if (_q_converged.empty())
      _problem.reset_th_state();
    else
      std::copy(_q_converged.begin(), _q_converged.end(), q->mutable_array().begin());
    q->scatter_fwd();
  }
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

void NonlinearSolver::start_clean()
{
  _non_finite = false;
  _stagnated = false;
  _test_verdict = SNES_CONVERGED_ITERATING;
  _shell_failure.clear();
  _linear_error = 0;
  _trust_region_linear_failure = false;
  // a failed preconditioner keeps its failure, and KSPSetUp then fails every later
  // solve without applying it: a cut step starts clean (the shells' own solvers too)
  KSP outer;
  SNESGetKSP(_snes, &outer);
  for (KSP ksp : {outer, _inner, _u_ksp, _q_ksp, _soft, _schur})
    clear_preconditioner_failures(ksp);
  // a lagged Galerkin matrix from another step, or from the rejected iterates of
  // a cut one, may be far from this solve's Jacobians
  if (_coarsening)
    _coarsening->refresh_at_next_call();
}

NewtonReport NonlinearSolver::solve()
{
  start_clean();
  _step_lengths.clear();
  if (_constraint)
    _constraint->restrict_to(*_problem.u()->x(), _x);
  else
    VecCopy(_u_petsc, _x);
  const long inner_before = _inner_iterations;
  // a PETSc error inside the solve (SOR's "Zero diagonal", a failed
  // factorisation) fails this solve with PETSc's message: the stepper cuts the
  // step and, in the end, stops with advice -- no trace on the console
  PetscErrorCode error = 0;
  std::optional<QuietPetscErrors> quiet(std::in_place);
  if (!_cell_unknowns.empty())
  {
    start_three_field();
    error = SNESSolve(_snes, nullptr, _x_ext);
    if (!error and stopped_short_of_theta())
      error = finish_theta_with_full_steps();
    set_extended_state(_x_ext);
  }
  else if (_taylor_hood)
  {
    get_mixed_state(_x_ext);
    error = SNESSolve(_snes, nullptr, _x_ext);
    set_mixed_state(_x_ext);
  }
  else
  {
    error = SNESSolve(_snes, nullptr, _x);
    set_state(_x); // leave u (and omega_a) at the final iterate
  }
  quiet.reset();
  NewtonReport report = outcome(error, inner_before);
  if (_taylor_hood and report.converged)
  {
    auto q = _problem.th_state()->x();
    _q_converged.assign(q->array().begin(),
                        q->array().begin() + q->map()->size_local() * q->bs());
  }
  return report;
}

} // namespace muscle
