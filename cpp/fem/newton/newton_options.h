#pragma once

#include "fem/elements/muscle_problem.h"
#include "fem/linear/linear_solver.h"

#include <string>
#include <vector>

namespace muscle
{

/// Newton settings; PETSc command-line options (-snes_*, -ksp_*, -pc_*)
/// override them.  The linear solver's (LinearSettings) are named in
/// linear_solver_table() (fem/linear/linear_solvers.h).
struct NewtonOptions : LinearSettings
{
  double rtol = 1e-9;  ///< relative residual reduction
  double atol = 1e-10; ///< absolute residual norm [mN]
  int max_iterations = 25;
  /// F-bar elements: Newton on (u, theta, p) with the cell unknowns theta, p
  /// eliminated per cell (FbarCellUnknowns; robust under the stiff penalty),
  /// or -- false -- on u alone with theta = J0(u).  Same converged states.
  bool fbar_cell_unknowns = true;
  /// Largest constraint violation |J0(u) - theta| accepted at convergence.
  double fbar_constraint_tolerance = 1e-10;
  /// PETSc line search, chosen by measurement (BENCHMARKS.md, "Line searches"):
  /// "basic", the full Newton step, finishes every case with the fewest Newton
  /// iterations in all.  Every merit function fails somewhere under the stiff
  /// penalty: a bending or turning nearly incompressible body raises residual
  /// norm and energy along the straight Newton line, so "cp" creeps there and
  /// "bt" stalls, where full steps converge.
  std::string line_search = "basic";
  /// Give up early when the residual norm fell by less than
  /// `stagnation_reduction` (relative) over the last `stagnation_window`
  /// iterations: a line search creeping with tiny steps costs a full
  /// max_iterations before the step is cut anyway.  0 disables.
  int stagnation_window = 5;
  double stagnation_reduction = 1e-3;
  /// Give up when the line search accepted less than `creep_step` of the
  /// Newton step in `creep_window` successive iterations (cp creeping: each
  /// iteration gains a fraction of a per cent, too little for the stagnation
  /// test to see).  0 disables.
  int creep_window = 3;
  double creep_step = 0.01;

  /// The names linear_solver, line_search and near_null_space accept.
  static const std::vector<std::string>& linear_solvers();
  static const std::vector<std::string>& line_searches();
  static const std::vector<std::string>& near_null_spaces();
  /// InputError naming the option, its value and what is allowed.
  void validate() const;
};

/// What one nonlinear solve did.
struct NewtonReport
{
  bool converged = false;
  int iterations = 0;
  int linear_iterations = 0;
  std::string reason;                 ///< PETSc's converged/diverged reason
  /// DIVERGED_LINEAR_SOLVE: how the linear solver failed (describe_linear_failure)
  std::string linear_failure;
  std::vector<double> residual_norms; ///< one per Newton iteration, first = initial
  /// the line search's step length lambda of each Newton step (1: the full
  /// Newton step); empty without a line search (trust region)
  std::vector<double> step_lengths;
  KernelStatus kernel;                ///< activation kernel at the last evaluation
  bool non_finite = false;            ///< a residual evaluation produced NaN/inf
};

} // namespace muscle
