#include "fem/linear/vertex_star.h"

#include <algorithm>
#include <dolfinx/common/IndexMap.h>
#include <dolfinx/fem/DofMap.h>
#include <dolfinx/fem/FiniteElement.h>
#include <dolfinx/mesh/Mesh.h>
#include <dolfinx/mesh/cell_types.h>
#include <stdexcept>

using namespace dolfinx;

namespace muscle
{

std::vector<IS> vertex_star_patches(const fem::FunctionSpace& V,
                                    std::span<const std::int64_t> numbers)
{
  auto mesh = V.mesh();
  const mesh::Topology& topology = mesh->topology();
  const int tdim = topology.dim();
  auto cell_to_vertex = topology.connectivity(tdim, 0);
  const fem::DofMap& dofmap = *V.dofmap();
  const fem::ElementDofLayout& layout = dofmap.element_dof_layout();
  const int bs = dofmap.index_map_bs();
  const int nodes_per_cell = V.element()->space_dimension() / bs;
  // the layout may number a blocked element's dofs unrolled (node * bs + k)
  const int per_node = layout.num_dofs() == nodes_per_cell ? 1 : bs;
  if (layout.num_dofs() != nodes_per_cell * per_node)
    throw std::logic_error("vertex_star_patches: the element's dof layout does not match "
                           "its dofmap");

  // only the owner's star: a vertex relaxed by two ranks is corrected twice, and
  // that costs more outer iterations than the cells a rank's star may lack
  // (measured on the fusiform on two ranks)
  const std::int32_t owned_vertices = topology.index_map(0)->size_local();
  std::vector<std::vector<std::int32_t>> star_nodes(owned_vertices);
  std::vector<graph::AdjacencyList<int>> entity_vertices; // per dimension, of the cell
  for (int d = 0; d <= tdim; ++d)
    entity_vertices.push_back(mesh::get_entity_vertices(topology.cell_type(), d));
  const std::int32_t num_cells = topology.index_map(tdim)->size_local()
                                 + topology.index_map(tdim)->num_ghosts();
  for (std::int32_t c = 0; c < num_cells; ++c)
  {
    auto cell_nodes = dofmap.cell_dofs(c);
    auto cell_vertices = cell_to_vertex->links(c);
    for (int d = 0; d <= tdim; ++d)
      for (int e = 0; e < entity_vertices[d].num_nodes(); ++e)
        for (int local_vertex : entity_vertices[d].links(e))
        {
          const std::int32_t vertex = cell_vertices[local_vertex];
          if (vertex >= owned_vertices)
            continue;
          for (int dof : layout.entity_dofs(d, e))
            star_nodes[vertex].push_back(cell_nodes[dof / per_node]);
        }
  }

  const common::IndexMap& node_map = *dofmap.index_map;
  if (!numbers.empty()
      and numbers.size() != std::size_t(bs) * (node_map.size_local() + node_map.num_ghosts()))
    throw std::logic_error("vertex_star_patches: one number per local dof expected");
  std::vector<IS> patches;
  patches.reserve(owned_vertices + 1);
  std::vector<std::int64_t> global_nodes;
  std::vector<PetscInt> dofs;
  const std::int32_t owned_nodes = node_map.size_local();
  std::vector<bool> covered(owned_nodes, false);
  auto add_patch = [&](const std::vector<std::int32_t>& nodes)
  {
    global_nodes.resize(nodes.size());
    node_map.local_to_global(nodes, global_nodes);
    dofs.clear();
    for (std::size_t i = 0; i < nodes.size(); ++i)
      for (int k = 0; k < bs; ++k)
      {
        const std::int64_t dof = numbers.empty() ? global_nodes[i] * bs + k
                                                 : numbers[nodes[i] * bs + k];
        if (dof >= 0)
          dofs.push_back(dof);
      }
    std::sort(dofs.begin(), dofs.end());
    IS patch;
    ISCreateGeneral(PETSC_COMM_SELF, dofs.size(), dofs.data(), PETSC_COPY_VALUES, &patch);
    patches.push_back(patch);
  };
  for (std::int32_t v = 0; v < owned_vertices; ++v)
  {
    std::vector<std::int32_t>& star = star_nodes[v];
    if (star.empty())
      continue;
    std::sort(star.begin(), star.end());
    star.erase(std::unique(star.begin(), star.end()), star.end());
    for (std::int32_t node : star)
      if (node < owned_nodes)
        covered[node] = true;
    add_patch(star);
  }
  // owned nodes in no owned vertex's star here (their cells' vertices all owned
  // elsewhere): one block, so that the smoother still reaches every unknown
  std::vector<std::int32_t> left;
  for (std::int32_t node = 0; node < owned_nodes; ++node)
    if (!covered[node])
      left.push_back(node);
  if (!left.empty() or patches.empty())
    add_patch(left);
  return patches;
}

} // namespace muscle
