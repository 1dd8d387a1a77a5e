#pragma once

#include <dolfinx/fem/FunctionSpace.h>
#include <petscmat.h>

namespace muscle
{
class DisplacementConstraint;

/// Rigid-body modes of a 3-D displacement space, for GAMG: on V's unknowns, or,
/// under a constraint, restricted to the reduced unknowns (the uniform-axial
/// set takes the mode's mean; a tie keeps the master's values).  Without them
/// GAMG coarsens the free muscle's system as a scalar problem (BENCHMARKS.md).
/// An orthonormal basis; the caller destroys the null space.
MatNullSpace rigid_body_modes(const dolfinx::fem::FunctionSpace& V,
                              const DisplacementConstraint* constraint);

} // namespace muscle
