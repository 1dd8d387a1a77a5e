#include "fem/geometry/surface_facets.h"

#include "common/errors.h"

#include <algorithm>
#include <dolfinx/common/IndexMap.h>
#include <dolfinx/fem/DofMap.h>
#include <dolfinx/mesh/Mesh.h>

using namespace dolfinx;

namespace muscle
{
std::vector<LocalSurfaceFacet> owned_surface_facets(const fem::FunctionSpace& V,
                                                   const std::vector<std::int32_t>& facets,
                                                   const std::string& name)
{
  auto mesh = V.mesh();
  const int tdim = mesh->topology().dim();
  auto& topology = const_cast<mesh::Topology&>(mesh->topology());
  topology.create_connectivity(tdim - 1, tdim);
  topology.create_connectivity(tdim, tdim - 1);
  auto f_to_c = topology.connectivity(tdim - 1, tdim);
  auto c_to_f = topology.connectivity(tdim, tdim - 1);
  const std::int32_t owned = topology.index_map(tdim - 1)->size_local();
  const fem::DofMap& dofmap = *V.dofmap();
  const fem::ElementDofLayout& layout = dofmap.element_dof_layout();
  const std::vector<double> X = V.tabulate_dof_coordinates(false);
  std::vector<LocalSurfaceFacet> out;
  for (std::int32_t f : facets)
  {
    if (f >= owned)
      continue;
    const std::int32_t c = f_to_c->links(f)[0];
    auto cf = c_to_f->links(c);
    const int local = std::distance(cf.begin(), std::find(cf.begin(), cf.end(), f));
    const std::vector<int>& closure = layout.entity_closure_dofs(tdim - 1, local);
    if (closure.size() > 4)
      throw InputError(name + ": needs elements of degree 1 (element.degree: 1)");
    auto cell_dofs = dofmap.cell_dofs(c);
    LocalSurfaceFacet facet;
    facet.reference.n = closure.size();
    for (int k = 0; k < facet.reference.n; ++k)
    {
      const std::int32_t b = cell_dofs[closure[k]];
      facet.block[k] = b;
      facet.reference.node[k] = b; // local for now: tensor_order keeps x, node together
      facet.reference.x[k] = {X[3 * b], X[3 * b + 1], X[3 * b + 2]};
    }
    tensor_order(facet.reference);
    for (int k = 0; k < facet.reference.n; ++k)
    {
      facet.block[k] = static_cast<std::int32_t>(facet.reference.node[k]);
      dofmap.index_map->local_to_global(std::span<const std::int32_t>(&facet.block[k], 1),
                                        std::span<std::int64_t>(&facet.reference.node[k], 1));
    }
    // outward: away from the centre of the facet's cell
    Point cell_centre{};
    for (std::int32_t b : cell_dofs)
      for (int k = 0; k < 3; ++k)
        cell_centre[k] += X[3 * b + k] / cell_dofs.size();
    facet.orientation
        = dot(facet_normal(facet.reference), sub(facet_centre(facet.reference), cell_centre)) > 0 ? 1
                                                                                            : -1;
    out.push_back(facet);
  }
  return out;
}

} // namespace muscle
