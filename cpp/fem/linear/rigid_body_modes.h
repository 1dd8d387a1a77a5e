#pragma once

#include <cstdint>
#include <dolfinx/fem/FunctionSpace.h>
#include <petscmat.h>
#include <vector>

namespace muscle
{
class DisplacementConstraint;

/// The separately meshed bodies of V's mesh: the connected pieces of the graph
/// of nodes joined by cells (a tie joins no cells, so tied bodies stay apart;
/// the parts of one conforming mesh are one body).
struct MeshBodies
{
  std::vector<std::int32_t> of_node; ///< local node (dof block, owned + ghost) -> body
  int count = 0;                     ///< bodies over all ranks
};
/// Collective.
MeshBodies mesh_bodies(const dolfinx::fem::FunctionSpace& V);

/// Rigid-body modes of a 3-D displacement space, for GAMG: on V's unknowns, or,
/// under a constraint, restricted to the reduced unknowns (the uniform-axial
/// set takes the mode's mean; a tie keeps the master's values).  Without them
/// GAMG coarsens the free muscle's system as a scalar problem (BENCHMARKS.md,
/// "Linear solvers, ranks and n = 4").
/// `per_body`: six modes of each body of mesh_bodies, each nonzero on that body
/// only (with one body the same six); GAMG then carries 6 x bodies coarse
/// unknowns per aggregate, and needed more iterations than with the global six
/// (BENCHMARKS.md, "Stiff-soft bodies").  An orthonormal basis; the caller
/// destroys the null space.
MatNullSpace rigid_body_modes(const dolfinx::fem::FunctionSpace& V,
                              const DisplacementConstraint* constraint, bool per_body);

} // namespace muscle
