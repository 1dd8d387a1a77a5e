#include "common/errors.h"
#include "forms/form_registry.h"

#include <map>
#include <utility>

namespace muscle::forms
{
// default quadrature degree per (cell, degree); mirrors forms/muscleforms/variants.py
int default_quadrature_degree(const std::string& cell, int degree)
{
  static const std::map<std::pair<std::string, int>, int> table
      = {{{"hexahedron", 1}, 2},
         {{"hexahedron", 2}, 4},
         {{"tetrahedron", 1}, 2},
         {{"tetrahedron", 2}, 4}};
  auto it = table.find({cell, degree});
  return it == table.end() ? -1 : it->second;
}

std::string element_not_compiled(const std::string& cell, int degree)
{
  const std::string name = cell.substr(0, 3) + std::to_string(degree);
  const std::string compiled = compiled_elements();
  if (("," + compiled + ",").find("," + name + ",") != std::string::npos)
    return "";
  return " This build compiled the elements " + compiled + " only, not " + name
         + ": `tools/muscle build` (or cmake -DMUSCLE_ELEMENTS=all) adds the others.";
}

const FeVariant& find_fe_variant(const std::string& model,
                                 const std::string& cell, int degree,
                                 int quadrature_degree,
                                 int volumetric_quadrature_degree, bool fbar,
                                 bool taylor_hood)
{
  if (quadrature_degree < 0)
    quadrature_degree = default_quadrature_degree(cell, degree);
  if (volumetric_quadrature_degree < 0)
    volumetric_quadrature_degree = quadrature_degree;
  auto describe = [](const FeVariant& v)
  {
    std::string s = std::string(v.cell) + " degree " + std::to_string(v.degree)
                    + " quadrature " + std::to_string(v.quadrature_degree);
    if (v.volumetric_quadrature_degree != v.quadrature_degree)
      s += " (volumetric " + std::to_string(v.volumetric_quadrature_degree) + ")";
    if (v.fbar)
      s += " F-bar";
    if (v.taylor_hood)
      s += " Taylor-Hood";
    return s;
  };
  std::vector<std::string> available;
  for (const FeVariant& v : fe_variants())
  {
    if (model == v.model and cell == v.cell and degree == v.degree
        and quadrature_degree == v.quadrature_degree
        and volumetric_quadrature_degree == v.volumetric_quadrature_degree
        and fbar == (v.fbar != nullptr) and taylor_hood == (v.taylor_hood != nullptr))
    {
      return v;
    }
    if (model == v.model)
      available.push_back(describe(v));
  }
  std::string wanted = "quadrature degree " + std::to_string(quadrature_degree);
  if (volumetric_quadrature_degree != quadrature_degree)
    wanted += " and volumetric quadrature degree "
              + std::to_string(volumetric_quadrature_degree);
  if (fbar)
    wanted += " as F-bar element";
  if (taylor_hood)
    wanted += " as Taylor-Hood element";
  // the likeliest reason first: a build for one job leaves whole elements out
  std::string why = element_not_compiled(cell, degree);
  if (why.empty() and *compiled_variants())
    why = " This build compiled only the variants whose name matches \""
          + std::string(compiled_variants())
          + "\" (MUSCLE_VARIANTS): `tools/muscle build` (or cmake -DMUSCLE_VARIANTS=) adds "
            "the others.";
  else if (why.empty() and fbar)
    why = " F-bar is compiled for hexahedra of degree 1 with quadrature degree 2 (Q2 does "
          "not lock; on tetrahedra the centre value is the whole P1 field).";
  else if (why.empty() and taylor_hood)
    why = " Taylor-Hood is compiled for degree-2 displacements (Q2-Q1 hexahedra, P2-P1 "
          "tetrahedra) with the default quadrature degree.";
  else if (why.empty() and volumetric_quadrature_degree != quadrature_degree)
    why = " The anti-locking element is compiled on hexahedra of degree 1 for the laws "
          "whose file gives volumetric_stiff_part (BLE: WKM, GIANT and COMBI need their "
          "coupled penalty at every quadrature point; BENCHMARKS.md). The locking-free "
          "Q1 of every law is the F-bar element (the default).";
  // listed here, not with errors.h's join: the registry library does not link libmuscle
  std::string listed;
  for (const std::string& a : available)
    listed += (listed.empty() ? "" : "; ") + a;
  throw InputError("no compiled kernels for model " + model + " on " + cell
                   + " degree " + std::to_string(degree) + " with " + wanted
                   + "; compiled: " + listed + "." + why
                   + " Add a variant with cmake -DMUSCLE_EXTRA_VARIANTS="
                     "KERNELS:CELL:DEGREE:QDEG[:VQDEG] (cell hex or tet) and rebuild.");
}

const MaterialPointVariant& find_material_point_variant(const std::string& model)
{
  for (const MaterialPointVariant& v : material_point_variants())
    if (model == v.model)
      return v;
  throw InputError("no material-point kernels for model " + model);
}

} // namespace muscle::forms
