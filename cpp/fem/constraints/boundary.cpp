#include "fem/constraints/boundary.h"

#include <dolfinx/la/Vector.h>
#include <limits>

using namespace dolfinx;

namespace muscle
{

std::vector<std::int32_t> tagged_facets(const mesh::MeshTags<std::int32_t>& tags, int tag)
{
  return tags.find(tag);
}

std::shared_ptr<const fem::DirichletBC<double>>
clamp(std::shared_ptr<fem::FunctionSpace> V, const std::vector<std::int32_t>& facets)
{
  return std::make_shared<fem::DirichletBC<double>>(
      std::vector<double>{0, 0, 0}, fem::locate_dofs_topological(*V, 2, facets), V);
}

std::vector<std::int32_t> component_dofs(const fem::FunctionSpace& V,
                                         const std::vector<std::int32_t>& facets,
                                         int component)
{
  return fem::locate_dofs_topological(*V.sub({component}), 2, facets);
}

std::shared_ptr<const fem::DirichletBC<double>>
prescribe_component(std::shared_ptr<fem::FunctionSpace> V,
                    const std::vector<std::int32_t>& facets, int component,
                    std::shared_ptr<fem::Constant<double>> value)
{
  return std::make_shared<fem::DirichletBC<double>>(
      value, component_dofs(*V, facets, component), V->sub({component}));
}

std::shared_ptr<const fem::DirichletBC<double>>
fix_nearest_node(std::shared_ptr<fem::FunctionSpace> V, const std::array<double, 3>& x,
                 std::array<double, 3>& node)
{
  const std::vector<double> coords = V->tabulate_dof_coordinates(false);
  const std::size_t n = coords.size() / 3;
  auto distance2 = [&](std::size_t i, const std::array<double, 3>& p)
  {
    double d = 0;
    for (int k = 0; k < 3; ++k)
      d += (coords[3 * i + k] - p[k]) * (coords[3 * i + k] - p[k]);
    return d;
  };
  struct
  {
    double d;
    int rank;
  } best{std::numeric_limits<double>::infinity(), 0};
  MPI_Comm comm = V->mesh()->comm();
  MPI_Comm_rank(comm, &best.rank);
  std::size_t nearest = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (const double d = distance2(i, x); d < best.d)
    {
      best.d = d;
      nearest = i;
    }
  for (int k = 0; k < 3; ++k)
    node[k] = n ? coords[3 * nearest + k] : 0.0;
  MPI_Allreduce(MPI_IN_PLACE, &best, 1, MPI_DOUBLE_INT, MPI_MINLOC, comm);
  MPI_Bcast(node.data(), 3, MPI_DOUBLE, best.rank, comm);
  // the node's copies on every rank (owned or ghost) are fixed alike
  std::vector<std::int32_t> dofs;
  for (std::size_t i = 0; i < n; ++i)
    if (distance2(i, node) == 0)
      dofs.push_back(static_cast<std::int32_t>(i));
  return std::make_shared<fem::DirichletBC<double>>(std::vector<double>{0, 0, 0}, dofs, V);
}

double sum_owned(const la::Vector<double>& b, const std::vector<std::int32_t>& dofs)
{
  const std::int32_t owned = b.map()->size_local() * b.bs();
  double local = 0;
  for (std::int32_t d : dofs)
    if (d < owned)
      local += b.array()[d];
  double total = 0;
  MPI_Allreduce(&local, &total, 1, MPI_DOUBLE, MPI_SUM, b.map()->comm());
  return total;
}

} // namespace muscle
