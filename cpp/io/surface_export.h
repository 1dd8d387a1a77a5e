#pragma once

#include <dolfinx/fem/Function.h>
#include <string>

namespace muscle
{

/// Write the deformed boundary surface as JSON for rendering without a
/// visualisation stack: every exterior facet with its vertices moved by `u`
/// and the value of the cell-wise field `cell_value` (DG0) of its cell.
/// Gathered on rank 0.  {"facets": [[[x,y,z], ...], ...], "values": [...]}
void export_deformed_surface(const dolfinx::fem::Function<double>& u,
                             const dolfinx::fem::Function<double>& cell_value,
                             const std::string& path);

} // namespace muscle
