#pragma once

#include <cstdint>
#include <dolfinx/fem/FunctionSpace.h>
#include <petscis.h>
#include <span>
#include <vector>

namespace muscle
{

/// The vertex-star patches of a vector function space V, as PETSc index sets of
/// global (unrolled) dof numbers, the patches of star_relaxation.h: for every
/// vertex this rank owns, the dofs of every entity whose closure holds the vertex (the
/// vertex, its edges, faces and cells), from the cells this rank sees (its own
/// and the ghosts).  On Q2 hexahedra an interior vertex's patch is 27 nodes (81
/// dofs), the interior of its 2 x 2 x 2 cells.
///
/// Why stars: an augmented-Lagrangian displacement block has a large near-kernel
/// (fields nearly free of the penalised dilation) that point smoothers such as
/// Jacobi cannot relax and that a coarser space cannot represent; relaxation on
/// vertex stars spans it locally (Schöberl's kernel decomposition, as in
/// augmented-Lagrangian multigrid for incompressible flow).
///
/// A vertex on a partition boundary is relaxed by its owner only (its star may
/// lack a cell that touches it only at an edge or a vertex).  Owned dofs in no
/// owned star form one more block, the last; a rank with none of either gets one
/// empty block (PCASM, which the tests compare with, needs one per rank).  The
/// caller owns the index sets (ISDestroy each).  Not collective.
///
/// `numbers`, if given: per local (owned and ghost) unrolled dof of V, the row
/// number of the operator to use for it, or -1 to leave it out (the reduced
/// unknowns under a linear constraint, DisplacementConstraint::reduced_numbers).
std::vector<IS> vertex_star_patches(const dolfinx::fem::FunctionSpace& V,
                                    std::span<const std::int64_t> numbers = {});

} // namespace muscle
