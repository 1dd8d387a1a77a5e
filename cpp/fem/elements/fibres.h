#pragma once

#include <dolfinx/fem/Function.h>
#include <dolfinx/mesh/Mesh.h>
#include <dolfinx/mesh/MeshTags.h>
#include <memory>

namespace muscle
{

/// Fibre field from a Laplace potential: phi = 0 on the `from` facets, 1 on
/// the `to` facets, zero flux elsewhere; the fibre of a cell is the normalised
/// gradient of phi at its midpoint.
struct LaplaceFibres
{
  std::shared_ptr<dolfinx::fem::Function<double>> potential; ///< P1
  std::shared_ptr<dolfinx::fem::Function<double>> fibre;     ///< DG0 vector, unit
};

/// `fibre_space`: the DG0 vector space the fibre is written into (that of the
/// muscle problem).  Solved with a direct solver, so the field is the same on
/// any number of ranks to round-off.
/// `cells`: the local cells of the part that needs the fibre (default all):
/// the potential is solved on them alone (zero at every other dof), the other
/// cells keep a zero vector.  A cell without gradient stops every rank
/// (InputError).
LaplaceFibres laplace_fibres(std::shared_ptr<dolfinx::mesh::Mesh> mesh,
                             const dolfinx::mesh::MeshTags<std::int32_t>& facet_tags,
                             int from_tag, int to_tag,
                             std::shared_ptr<const dolfinx::fem::FunctionSpace> fibre_space,
                             const std::vector<std::int32_t>* cells = nullptr);

} // namespace muscle
