#pragma once

#include <array>
#include <cstdint>
#include <dolfinx/fem/Function.h>
#include <vector>

namespace muscle
{

/// The rotation of a body as a whole: the rotation R of the best rigid fit
/// x = R X + c to its nodes (Kabsch: R from the SVD of sum (X - X_m)(x - x_m)^T),
/// as the rotation vector axis x angle, in degrees.  `cells`: the body's local
/// cells (its owned nodes count once).  Collective.
std::array<double, 3> rotation_vector(const dolfinx::fem::Function<double>& u,
                                      const std::vector<std::int32_t>& cells);

} // namespace muscle
