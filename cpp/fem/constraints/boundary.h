#pragma once

#include <dolfinx/fem/Constant.h>
#include <dolfinx/fem/DirichletBC.h>
#include <dolfinx/fem/FunctionSpace.h>
#include <dolfinx/mesh/MeshTags.h>
#include <memory>
#include <vector>

namespace muscle
{

/// A body's Dirichlet conditions.
using DirichletBCs = std::vector<std::shared_ptr<const dolfinx::fem::DirichletBC<double>>>;

/// Facets carrying a tag; empty vector if none on this rank.
std::vector<std::int32_t> tagged_facets(const dolfinx::mesh::MeshTags<std::int32_t>& tags,
                                        int tag);

/// All three displacement components fixed to zero on the facets.
std::shared_ptr<const dolfinx::fem::DirichletBC<double>>
clamp(std::shared_ptr<dolfinx::fem::FunctionSpace> V, const std::vector<std::int32_t>& facets);

/// One component prescribed on the facets; change `value->value` to move it.
std::shared_ptr<const dolfinx::fem::DirichletBC<double>>
prescribe_component(std::shared_ptr<dolfinx::fem::FunctionSpace> V,
                    const std::vector<std::int32_t>& facets, int component,
                    std::shared_ptr<dolfinx::fem::Constant<double>> value);

/// All three components fixed to zero at the node nearest `x` (of the
/// displacement's nodes; every rank that holds the node fixes it).  `node`
/// receives its coordinates.  Collective.
std::shared_ptr<const dolfinx::fem::DirichletBC<double>>
fix_nearest_node(std::shared_ptr<dolfinx::fem::FunctionSpace> V, const std::array<double, 3>& x,
                 std::array<double, 3>& node);

/// Unrolled local indices of one component's dofs on the facets.
std::vector<std::int32_t> component_dofs(const dolfinx::fem::FunctionSpace& V,
                                         const std::vector<std::int32_t>& facets,
                                         int component);

/// Sum over ranks of b at the given local dofs (owned entries only).
double sum_owned(const dolfinx::la::Vector<double>& b, const std::vector<std::int32_t>& dofs);

} // namespace muscle
