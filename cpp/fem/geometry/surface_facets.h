#pragma once

#include "fem/geometry/surface_geometry.h"

#include <dolfinx/fem/FunctionSpace.h>
#include <string>
#include <vector>

namespace muscle
{

/// A facet of a surface on this rank: reference coordinates with global node
/// numbers (tensor order), the local node (block) indices, and the sign that
/// turns its a1 x a2 outward (away from its cell).
struct LocalSurfaceFacet
{
  SurfaceFacet reference;
  std::array<std::int32_t, 4> block{};
  int orientation = 1;
};

/// The owned facets among `facets` (local indices) of a degree-1 space; `name`
/// locates the InputError for higher degrees.
std::vector<LocalSurfaceFacet> owned_surface_facets(const dolfinx::fem::FunctionSpace& V,
                                                   const std::vector<std::int32_t>& facets,
                                                   const std::string& name);

} // namespace muscle
