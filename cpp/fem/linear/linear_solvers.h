#pragma once

#include "fem/constraints/boundary.h"
#include "fem/linear/linear_solver.h"
#include "fem/linear/penalty_split.h"
#include "fem/linear/taylor_hood_split.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace muscle
{

/// A linear solver by name: what it is and, for each kind of Newton system,
/// how it is made there (a null factory: it does not fit that system).
struct LinearSolverType
{
  std::string name;
  std::string summary; ///< for --help
  /// on an assembled displacement matrix: the displacement Newton's, F-bar's condensed one
  std::function<std::unique_ptr<MatrixSolver>(const LinearSettings&, const DisplacementSpace&)>
      matrix;
  /// `matrix` also on the Taylor-Hood system assembled into one matrix
  bool on_assembled_blocks = false;
  /// on F-bar's three-field Newton, through the cells' linearisation (before `matrix`)
  std::function<std::unique_ptr<PenaltySplit>(
      const LinearSettings&, const DisplacementSpace&,
      const std::vector<std::unique_ptr<FbarCellUnknowns>>&, Mat A, Vec layout)>
      condensed;
  /// on the Taylor-Hood block system
  std::function<std::unique_ptr<TaylorHoodSplit>(const LinearSettings&, const DisplacementSpace&,
                                                 const DirichletBCs&, const ParameterSet&,
                                                 const std::string& kernels)>
      blocks;
  /// InputError's text for a system without pressure unknowns (displacement,
  /// F-bar) that it does not fit
  std::string refused;
};

/// Every linear solver, the default ("lu") first.
const std::vector<LinearSolverType>& linear_solver_table();
/// Their names, in the table's order.
const std::vector<std::string>& linear_solver_names();
/// The entry named `name` (InputError with what is allowed if there is none).
const LinearSolverType& linear_solver_type(const std::string& name);

/// InputError: linear solver `type` does not fit the Taylor-Hood system.
[[noreturn]] void refuse_on_taylor_hood(const LinearSolverType& type);
/// InputError: linear solver `type` does not fit a system without pressure unknowns.
[[noreturn]] void refuse_without_pressure(const LinearSolverType& type);

} // namespace muscle
