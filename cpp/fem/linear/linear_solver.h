#pragma once

#include "common/petsc_handle.h"

#include <dolfinx/fem/FunctionSpace.h>
#include <memory>
#include <petscksp.h>
#include <string>
#include <vector>

namespace muscle
{
class DisplacementConstraint;

/// The settings every linear solver reads; the Newton options (NewtonOptions)
/// hold them.  PETSc options (-ksp_*, -pc_*) override them.
struct LinearSettings
{
  /// A name of linear_solver_table() (linear_solvers.h).
  std::string linear_solver = "lu";
  /// GAMG's near-null space: "global", six rigid-body modes for the whole mesh,
  /// or "bodies", six per separately meshed body (mesh_bodies).  Global by
  /// measurement (BENCHMARKS.md, "Stiff-soft bodies").
  std::string near_null_space = "global";
  /// GAMG: the tie-reduced matrix carries block size 3 where its unknowns are
  /// whole nodes (DisplacementConstraint::keeps_whole_nodes), so that GAMG
  /// aggregates nodes, not single components.
  bool reduced_blocks = true;
  /// Relative tolerance of the iterative linear solvers (Newton converges
  /// quadratically down to about this reduction per step).
  double linear_rtol = 1e-10;
};

/// The displacement space a solver works on, and the constraint u = T x whose
/// reduced unknowns it solves for (null: u's own dofs).
struct DisplacementSpace
{
  std::shared_ptr<const dolfinx::fem::FunctionSpace> V;
  const DisplacementConstraint* constraint = nullptr;
};

/// A linear solver of the Newton steps.  Each kind of system has its own
/// subclass interface (MatrixSolver here, PenaltySplit, TaylorHoodSplit); what
/// they share is how a Newton solve starts clean and how an inner failure is
/// told.
class LinearSolver
{
public:
  virtual ~LinearSolver() = default;
  /// The solvers nested in its preconditioner: a new Newton solve clears their
  /// failures (clear_preconditioner_failures).
  virtual std::vector<KSP> nested() const { return {}; }
  /// Before each Newton solve (the inner failure forgotten, lagged parts refreshed).
  virtual void start_solve() { _inner_failure.clear(); }
  /// Which inner solve of its preconditioner failed, and how ("" if none).
  const std::string& inner_failure() const { return _inner_failure; }

protected:
  std::string _inner_failure;
};

/// A solver of an assembled displacement matrix: the displacement Newton's
/// (A, or T^T A T under a constraint), the F-bar three-field Newton's
/// condensed one, Taylor-Hood's assembled block matrix (MUMPS only).
class MatrixSolver : public LinearSolver
{
public:
  /// Type, tolerances and preconditioner of `ksp`.
  virtual void configure(KSP ksp) = 0;
  /// The matrix it will solve with, `op`, is made (full: A itself; under a
  /// constraint T^T A T): what the preconditioner reads off it (GAMG's
  /// near-null space).  Called again when a new operator object is made.
  virtual void operator_made(Mat full, Mat op) { (void)full, (void)op; }
  /// Block size of T^T A T (GAMG aggregates whole nodes where it can).
  virtual int reduced_block_size() const { return 1; }
};

/// MUMPS (linear: lu): KSPPREONLY with an LU factorisation.
class DirectSolver : public MatrixSolver
{
public:
  void configure(KSP ksp) override;
};

/// GMRES with algebraic multigrid: BoomerAMG (linear: gmres-hypre) or GAMG with
/// the rigid-body modes as its near-null space (linear: gmres-gamg).
class AmgSolver : public MatrixSolver
{
public:
  enum class Type
  {
    hypre,
    gamg
  };
  AmgSolver(Type type, const LinearSettings& settings, DisplacementSpace space);
  void configure(KSP ksp) override;
  void operator_made(Mat full, Mat op) override;
  int reduced_block_size() const override;

private:
  Type _type;
  LinearSettings _settings;
  DisplacementSpace _space;
  NullSpaceHandle _modes;
};

/// GMRES with right preconditioning and the long restart every iterative
/// solver here takes (a restart throws the Krylov space away and slows the
/// convergence).
void configure_gmres(KSP ksp, double rtol);
inline constexpr PetscInt gmres_restart = 200;

} // namespace muscle
