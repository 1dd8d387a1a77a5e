#pragma once

#include "fem/elements/muscle_problem.h"
#include "fem/linear/linear_solver.h"

#include <memory>
#include <petscsnes.h>
#include <vector>

namespace muscle
{
class DisplacementSystem;
struct NewtonOptions;

/// What an element makes of the displacement system (displacement_system.h):
/// the unknowns Newton solves for, the residual and Jacobian there, the linear
/// solver of its Newton steps and the fields it keeps between solves.  The
/// SNES driver (nonlinear_solver.h) knows formulations only through this
/// interface; a new element is a new subclass and one line in
/// make_formulation.
///
/// * DisplacementFormulation: u (reduced under a constraint) -- plain
///   elements, F-bar with theta = J0(u);
/// * FbarFormulation: [u | theta, p per cell], the cells eliminated around a
///   condensed displacement solve;
/// * TaylorHoodFormulation: [u | q], q = (theta, p) continuous of degree 1.
class Formulation
{
public:
  virtual ~Formulation() = default;

  /// The SNES iterate (owned here; the residual has its layout).
  virtual Vec iterate() const = 0;
  /// The matrix SNES holds as its Jacobian.
  virtual Mat matrix() const = 0;
  /// iterate() from the current fields: the start of a solve.
  virtual void start() = 0;
  /// The fields at the iterate x (u, and q or the cells' unknowns), then the
  /// activation kernels there.
  virtual KernelStatus set_state(Vec x) = 0;

  /// The residual at the state last set.
  virtual void residual(Vec F) = 0;
  /// The Jacobian at the state last set, into matrix() (and what the linear
  /// solver reads off it); matrix_norm() NaN when it is not finite.
  virtual void jacobian() = 0;
  virtual double matrix_norm() const = 0;
  /// The residual norm at which SNES's current iterate counts as converged
  /// whatever the tolerances: a safe multiple of the round-off level (`xnorm`:
  /// the iterate's norm as SNES computed it).  With a stiff penalty that level
  /// can lie above any fixed atol, and Newton would stagnate there.
  virtual double convergence_floor(SNES snes, double xnorm) const = 0;
  /// A constraint the convergence test demands besides the residual (F-bar's
  /// |J0(u) - theta|), 0 if none.
  virtual double constraint_violation() const { return 0; }
  /// Whether the residual keeps Dirichlet rows u - g unlifted: then a moved
  /// boundary value is no gradient of the energy, and a merit-function line
  /// search stalls on it (the driver takes one full Newton step first).
  virtual bool keeps_dirichlet_rows() const { return false; }

  /// The SNES's KSP set up: the linear solver, or a shell around it.
  virtual void configure_linear_solver(KSP ksp) = 0;
  /// After SNESSetFromOptions (a shell that the options must not replace).
  virtual void after_options(KSP) {}
  /// The KSP of the displacement system (F-bar: of the condensed one).
  virtual KSP linear_ksp(KSP snes_ksp) const { return snes_ksp; }
  /// The linear solver of the Newton steps.
  virtual const LinearSolver& linear_solver() const = 0;
  /// The KSPs inside this formulation's linear solve, whose failures a new
  /// solve clears (the SNES's own KSP aside).
  virtual std::vector<KSP> nested() const { return linear_solver().nested(); }
  /// Before each solve: failures and lagged parts forgotten.
  virtual void start_clean() = 0;
  /// Linear iterations so far when counted here (F-bar's inner solves), else -1.
  virtual long inner_iterations() const { return -1; }
  /// The PETSc error of the last inner solve (F-bar's), 0 if none.
  virtual PetscErrorCode linear_error() const { return 0; }

  /// After a converged solve (Taylor-Hood keeps its q for a cut step).
  virtual void converged() {}
  /// After u was set from outside (a restored state): the other unknowns from it.
  virtual void restore() {}
  /// The last Newton matrix of the displacement unknowns (reduced if constrained).
  virtual Mat system_matrix() = 0;
  /// The full displacement tangent at the current state (fixed dofs: unit
  /// rows); InputError where the element's tangent holds more unknowns.
  virtual Mat assemble_tangent() = 0;
};

/// The formulation of the body's element: the one place where displacement,
/// F-bar and Taylor-Hood are told apart.
std::unique_ptr<Formulation> make_formulation(DisplacementSystem& system,
                                              const NewtonOptions& options);

} // namespace muscle
