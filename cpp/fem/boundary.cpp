#include "boundary.h"

#include <dolfinx/la/Vector.h>

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
