#include "../common/errors.h"
#include "form_registry.h"

#include <map>
#include <utility>

namespace muscle::forms
{
namespace
{
// default quadrature degree per (cell, degree); mirrors forms/muscleforms/variants.py
int default_quadrature(const std::string& cell, int degree)
{
  static const std::map<std::pair<std::string, int>, int> table
      = {{{"hexahedron", 1}, 2},
         {{"hexahedron", 2}, 4},
         {{"tetrahedron", 1}, 2},
         {{"tetrahedron", 2}, 4}};
  auto it = table.find({cell, degree});
  return it == table.end() ? -1 : it->second;
}
} // namespace

const FeVariant& find_fe_variant(const std::string& model,
                                 const std::string& cell, int degree,
                                 int quadrature_degree)
{
  if (quadrature_degree < 0)
    quadrature_degree = default_quadrature(cell, degree);
  std::vector<std::string> available;
  for (const FeVariant& v : fe_variants())
  {
    if (model == v.model and cell == v.cell and degree == v.degree
        and quadrature_degree == v.quadrature_degree)
    {
      return v;
    }
    if (model == v.model)
    {
      available.push_back(std::string(v.cell) + " degree "
                          + std::to_string(v.degree) + " quadrature "
                          + std::to_string(v.quadrature_degree));
    }
  }
  throw InputError("no compiled kernels for model " + model + " on " + cell
                   + " degree " + std::to_string(degree) + " with quadrature degree "
                   + std::to_string(quadrature_degree) + "; compiled: "
                   + join(available, "; ")
                   + ". Add it with cmake -DMUSCLE_EXTRA_VARIANTS="
                     "MODEL:CELL:DEGREE:QDEG (cell hex or tet) and rebuild.");
}

const MaterialPointVariant& find_material_point_variant(const std::string& model)
{
  for (const MaterialPointVariant& v : material_point_variants())
    if (model == v.model)
      return v;
  throw InputError("no material-point kernels for model " + model);
}

} // namespace muscle::forms
