#pragma once

#include "common/petsc_handle.h"

#include <cstdint>
#include <dolfinx/fem/FunctionSpace.h>
#include <memory>
#include <petscmat.h>
#include <span>

namespace muscle
{

/// The coarse level of p-multigrid on a degree-2 displacement space V (Q2 on
/// hexahedra, P2 on tetrahedra): the degree-1 space of the same mesh, the
/// prolongation P that interpolates its functions into V, and the Galerkin
/// coarse matrix P^T A P carrying the degree-1 space's rigid-body modes, for
/// GAMG.  Tried because algebraic multigrid coarsens a degree-2 matrix worse
/// than a degree-1 one, and the step from degree 2 to 1 is geometric.  On
/// Taylor-Hood's displacement block it saves Krylov iterations but grows with
/// the mesh as GAMG does: that block has no bulk stiffness, on
/// Q1 as on Q2, and that is what GAMG handles poorly (BENCHMARKS.md,
/// "Preconditioners against kappa").
class DegreeOneCoarsening
{
public:
  /// `dirichlet_dofs`: V's local (unrolled) dofs with Dirichlet conditions; P's
  /// rows there are zero, so the coarse correction leaves them as the smoother
  /// set them (A's rows there are unit rows, whose scale the coarse matrix must
  /// not see).  Collective.
  DegreeOneCoarsening(std::shared_ptr<const dolfinx::fem::FunctionSpace> V,
                      std::span<const std::int32_t> dirichlet_dofs);
  DegreeOneCoarsening(const DegreeOneCoarsening&) = delete;
  DegreeOneCoarsening& operator=(const DegreeOneCoarsening&) = delete;

  Mat prolongation() const { return _P; }
  /// P <- R P: the prolongation onto a linear constraint's reduced unknowns (R from
  /// DisplacementConstraint::restriction), before the product's first use.
  void restrict_rows(Mat R);
  /// The degree-1 space (the coarse level's unknowns).
  std::shared_ptr<const dolfinx::fem::FunctionSpace> coarse_space() const { return _V1; }
  /// P^T A P for the current A: recomputed in place while A keeps its nonzero
  /// pattern (contact can add entries: then made anew), with
  /// -fieldsplit_u_mg_coarse_lag N only at every N-th call (the calls between
  /// return the last one unchanged, so the AMG below keeps its hierarchy: the
  /// coarse level only preconditions, the outer Krylov method sees the true A).
  /// Owned here.
  Mat coarse_matrix(Mat A);
  /// The product's structure for A (options checked, symbolic phase) without its
  /// values: the next coarse_matrix(A) computes them.
  void prepare(Mat A);
  /// The next coarse_matrix(A) recomputes, whatever the lag (a new Newton solve).
  void refresh_at_next_call() { _calls_since = _lag - 1; }
  /// Newton iterations per Galerkin product (-fieldsplit_u_mg_coarse_lag).
  PetscInt lag() const { return _lag; }

private:
  std::shared_ptr<const dolfinx::fem::FunctionSpace> _V1;
  MatHandle _P;
  MatHandle _coarse;
  NullSpaceHandle _modes;
  PetscObjectState _pattern = -1; ///< A's nonzero state when _coarse was made
  PetscObjectId _operator = 0;     ///< and A itself: states of two objects do not compare
  PetscInt _lag = 1;               ///< -fieldsplit_u_mg_coarse_lag
  PetscInt _calls_since = 0;       ///< calls since _coarse was last computed
};

} // namespace muscle
