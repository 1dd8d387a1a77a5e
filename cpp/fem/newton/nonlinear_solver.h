#pragma once

#include "common/petsc_handle.h"
#include "common/petsc_options.h"
#include "fem/newton/displacement_system.h"
#include "fem/newton/newton_options.h"

#include <memory>
#include <petscsnes.h>
#include <string>
#include <vector>

namespace muscle
{
class Formulation;

struct NonlinearSolverTestAccess;

/// Newton's method (PETSc SNES) for a body's residual with Dirichlet conditions
/// and, optionally, a linear constraint (uniform-axial, tie): the SNES driver.
/// What the unknowns are, and the residual and Jacobian there, is the element's
/// formulation (formulation.h); this class owns the SNES -- its callbacks, the
/// convergence test (round-off floor, stagnation, a creeping line search), the
/// full Newton steps some formulations need -- and says why a solve failed.
/// The residual callback refreshes the quadrature-point activation kernels at
/// the evaluation point, so the tangent is exact at every iterate.  A
/// non-finite residual or a kernel without admissible root is reported to SNES
/// as a domain error (the line search then backtracks).
///
/// The PETSc options the solver sets (its linear solver's defaults) go into a
/// database of its own (SolverOptions), active while it sets up and solves:
/// the process's options and other solvers never see them.
class NonlinearSolver
{
  friend struct NonlinearSolverTestAccess; // the tests reach the SNES and the formulation
public:
  NonlinearSolver(MuscleProblem& problem, DirichletBCs bcs,
                  std::shared_ptr<const DisplacementConstraint> constraint = nullptr,
                  NewtonOptions options = {});

  /// A body of several parts (regions of one mesh with their own material)
  /// sharing one displacement: residuals and Jacobians are summed.
  NonlinearSolver(std::vector<MuscleProblem*> parts, DirichletBCs bcs,
                  std::shared_ptr<const DisplacementConstraint> constraint = nullptr,
                  NewtonOptions options = {});
  ~NonlinearSolver();
  NonlinearSolver(const NonlinearSolver&) = delete;
  NonlinearSolver& operator=(const NonlinearSolver&) = delete;

  /// Forms added to every residual and Jacobian (external loads, terms/loads.h):
  /// residuals of the displacement's test space, Jacobians on its trial space
  /// too, each with its own integration domains.
  void add_forms(std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> residuals,
                 std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> jacobians);

  /// A term added to every residual and Jacobian (contact, inertia).
  void add_term(std::shared_ptr<NonlinearTerm> term);

  /// Solve from the current displacement; on failure u holds the last iterate
  /// (callers restore their own copy).
  NewtonReport solve();

  /// The last assembled system matrix (reduced if constrained; the penalty split,
  /// which keeps only the reduced soft matrix, forms T^T A T anew on each call).
  Mat system_matrix();

  /// The full tangent at the current displacement (fixed dofs: unit rows), e.g.
  /// for natural frequencies.  InputError with F-bar cell unknowns, whose
  /// tangent is only ever condensed inside a solve, and with Taylor-Hood.
  Mat assemble_tangent();

  const NewtonOptions& options() const { return _options; }

  /// The line search SNES uses (options().line_search unless a PETSc option
  /// changed it; "" without one, e.g. -snes_type newtontr).
  std::string line_search() const;

  /// The KSP of the displacement system (with F-bar cell unknowns: of the
  /// condensed system), e.g. to change its tolerances between solves.
  KSP linear_solver() const;

  /// Assemble the residual without boundary conditions into `b` (owned +
  /// ghost entries, ghosts accumulated): nodal forces, e.g. reactions.
  void assemble_nodal_forces(dolfinx::la::Vector<double>& b) const;

  /// Activation kernels of every part at the current displacement.
  KernelStatus update_activation();

  /// After the displacement was set from outside (a restored state after a
  /// failed step): the formulation's other unknowns from it (F-bar: theta =
  /// J0(u), p = r_0; Taylor-Hood: the last converged q), then the activation
  /// kernels.
  KernelStatus restore_displacement();

  /// Smallest J over the quadrature points of every part's local cells.
  std::pair<double, std::int32_t> min_jacobian_determinant() const;

private:
  // newton_callbacks.cpp: what SNES calls back
  static PetscErrorCode residual_callback(SNES, Vec x, Vec F, void* ctx);
  static PetscErrorCode jacobian_callback(SNES, Vec x, Mat J, Mat P, void* ctx);
  /// After each linear solve under -snes_type newtontr, which PETSc 3.18 does not
  /// check: a failed one stops the Newton solve as a linear failure.
  static PetscErrorCode trust_region_linear_check(KSP ksp, Vec, Vec, void* ctx);
  static PetscErrorCode convergence_test(SNES, PetscInt it, PetscReal xnorm,
                                         PetscReal ynorm, PetscReal fnorm,
                                         SNESConvergedReason* reason, void* ctx);

  // nonlinear_solver.cpp
  void set_up_snes();
  /// Forget the last solve's failures (flags, messages, failed preconditioners).
  void start_clean();
  /// One full Newton step when boundary values moved and the formulation keeps
  /// its Dirichlet rows (see the definition).
  void first_full_step();
  /// SNESSolve with full Newton steps and at most `max_it` iterations.
  PetscErrorCode solve_with_full_steps(PetscInt max_it);
  /// The last SNESSolve converged by the line search alone, with the
  /// formulation's constraint unmet, after a nonzero Newton direction.
  bool stopped_short_of_constraint() const;
  /// The last Newton direction is zero (only a failed linear solve returns one).
  bool zero_update() const;
  /// Whether the line search crept: accepted less than creep_step of the Newton
  /// step in creep_window successive iterations.
  bool creeping() const;

  // newton_report.cpp: what a solve did, and why it failed
  NewtonReport outcome(PetscErrorCode error, long inner_iterations_before) const;

  SolverOptions _petsc_options; ///< the solver's own PETSc options (made first, gone last)
  NewtonOptions _options;
  DisplacementSystem _system;
  std::unique_ptr<Formulation> _formulation;
  SNESHandle _snes;

  KernelStatus _last_kernel;
  bool _non_finite = false;
  bool _stagnated = false;
  bool _crept = false;
  bool _trust_region_linear_failure = false;
  /// the convergence test's verdict on the last iterate it saw: PETSc can stop a
  /// solve as converged without asking it (the cp line search on a zero direction)
  SNESConvergedReason _test_verdict = SNES_CONVERGED_ITERATING;
  int _full_steps = 0; ///< Newton iterations taken in SNESSolves before the last one
  std::vector<double> _norms; ///< residual norms of the current solve
  std::vector<double> _step_lengths; ///< line-search lambdas of the current solve
};

} // namespace muscle
