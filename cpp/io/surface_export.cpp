#include "io/surface_export.h"

#include "common/errors.h"

#include <algorithm>
#include <dolfinx/mesh/utils.h>
#include <fstream>
#include <nlohmann/json.hpp>

using namespace dolfinx;

namespace muscle
{

void export_deformed_surface(
    const fem::Function<double>& u, const fem::Function<double>& cell_value,
    const std::string& path,
    const std::vector<std::shared_ptr<const fem::Function<double>>>& more)
{
  auto mesh = u.function_space()->mesh();
  auto& topology = mesh->topology_mutable();
  const int tdim = 3;
  topology.create_connectivity(tdim - 1, tdim);
  topology.create_connectivity(tdim - 1, 0);
  topology.create_connectivity(tdim, 0);
  auto f_to_c = topology.connectivity(tdim - 1, tdim);
  auto f_to_v = topology.connectivity(tdim - 1, 0);
  auto c_to_v = topology.connectivity(tdim, 0);
  const auto& x_dofmap = mesh->geometry().dofmap();
  std::span<const double> x = mesh->geometry().x();
  const auto& u_dofmap = *u.function_space()->dofmap();
  std::span<const double> uu = u.x()->array();
  const auto& v_dofmap = *cell_value.function_space()->dofmap();
  std::span<const double> values = cell_value.x()->array();

  // flat local data: per facet nv vertices x 3 coordinates, plus a value
  std::vector<double> coords, facet_values;
  std::vector<std::vector<double>> more_values(more.size());
  int nv = 0;
  for (std::int32_t f : mesh::exterior_facet_indices(topology))
  {
    const std::int32_t c = f_to_c->links(f)[0];
    auto cell_vertices = c_to_v->links(c);
    auto facet_vertices = f_to_v->links(f);
    nv = facet_vertices.size();
    // order the facet's vertices around its boundary (hexahedra: quads whose
    // DOLFINx vertex order is tensor-product, swap the last two)
    std::vector<std::int32_t> order(facet_vertices.begin(), facet_vertices.end());
    if (nv == 4)
      std::swap(order[2], order[3]);
    for (std::int32_t v : order)
    {
      const auto k = std::distance(cell_vertices.begin(),
                                   std::find(cell_vertices.begin(), cell_vertices.end(), v));
      const std::int32_t g = x_dofmap.links(c)[k];
      const std::int32_t d = u_dofmap.cell_dofs(c)[k];
      for (int i = 0; i < 3; ++i)
        coords.push_back(x[3 * g + i] + uu[3 * d + i]);
    }
    facet_values.push_back(values[v_dofmap.cell_dofs(c)[0]]);
    for (std::size_t m = 0; m < more.size(); ++m)
    {
      std::span<const double> a = more[m]->x()->array();
      const auto& dofmap = *more[m]->function_space()->dofmap();
      if (dofmap.bs() != 1)
        throw std::runtime_error("export_deformed_surface: '" + more[m]->name
                                 + "' is not a scalar field");
      const auto dofs = dofmap.cell_dofs(c);
      double v = 0;
      if (dofs.size() == 1)
        v = a[dofs[0]];
      else
      {
        for (std::int32_t w : order)
          v += a[dofs[std::distance(cell_vertices.begin(),
                                    std::find(cell_vertices.begin(), cell_vertices.end(), w))]];
        v /= order.size();
      }
      more_values[m].push_back(v);
    }
  }

  // gather on rank 0
  MPI_Comm comm = mesh->comm();
  int size, rank;
  MPI_Comm_size(comm, &size);
  MPI_Comm_rank(comm, &rank);
  auto gather = [&](std::vector<double>& local)
  {
    int n = local.size();
    std::vector<int> counts(size), displs(size);
    MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
    int total = 0;
    for (int r = 0; r < size; ++r)
    {
      displs[r] = total;
      total += counts[r];
    }
    std::vector<double> all(rank == 0 ? total : 0);
    MPI_Gatherv(local.data(), n, MPI_DOUBLE, all.data(), counts.data(), displs.data(),
                MPI_DOUBLE, 0, comm);
    return all;
  };
  int nv_max = 0;
  MPI_Allreduce(&nv, &nv_max, 1, MPI_INT, MPI_MAX, comm);
  const std::vector<double> all_coords = gather(coords);
  const std::vector<double> all_values = gather(facet_values);
  nlohmann::json fields = nlohmann::json::object();
  for (std::size_t m = 0; m < more.size(); ++m)
  {
    const std::vector<double> all = gather(more_values[m]);
    if (rank == 0)
      fields[more[m]->name] = all;
  }
  if (rank != 0)
    return;
  nlohmann::json facets = nlohmann::json::array();
  for (std::size_t f = 0; f < all_values.size(); ++f)
  {
    nlohmann::json facet = nlohmann::json::array();
    for (int k = 0; k < nv_max; ++k)
    {
      const double* p = all_coords.data() + 3 * (nv_max * f + k);
      facet.push_back({p[0], p[1], p[2]});
    }
    facets.push_back(facet);
  }
  std::ofstream out(path);
  if (!out)
    throw InputError("cannot write " + path);
  out << nlohmann::json{{"facets", facets}, {"values", all_values}, {"fields", fields}}.dump();
}

} // namespace muscle
