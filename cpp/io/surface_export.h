#pragma once

#include <dolfinx/fem/Function.h>
#include <memory>
#include <string>
#include <vector>

namespace muscle
{

/// Write the deformed boundary surface as JSON for rendering without a
/// visualisation stack: every exterior facet with its vertices moved by `u`,
/// the value of the cell-wise field `cell_value` (DG0) of its cell, and per
/// field of `more` (by its name) the facet's value: its cell's for a DG0 field,
/// the mean over its vertices for a degree-1 nodal one.  Gathered on rank 0.
/// {"facets": [[[x,y,z], ...], ...], "values": [...], "fields": {NAME: [...]}}
void export_deformed_surface(
    const dolfinx::fem::Function<double>& u, const dolfinx::fem::Function<double>& cell_value,
    const std::string& path,
    const std::vector<std::shared_ptr<const dolfinx::fem::Function<double>>>& more = {});

} // namespace muscle
