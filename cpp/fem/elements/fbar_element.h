#pragma once

#include <cstdint>
#include <dolfinx/fem/Form.h>
#include <functional>
#include <string>
#include <ufcx.h>
#include <vector>

namespace muscle
{
namespace forms
{
struct FbarForms;
}

/// A cell kernel as DOLFINx calls it: (A, coefficients, constants, coordinate
/// dofs, entity index, permutation); adds the element tensor into A.
using CellKernel = std::function<void(double*, const double*, const double*, const double*,
                                      const int*, const std::uint8_t*)>;

/// The F-bar hexahedron (forms/muscleforms/fbar.py).  FFCx gives the element on
/// (u, J0) with J0 = det F at the cell centre as an unknown of its own; these
/// kernels eliminate J0 = J0(u) cell by cell,
///
///     R = R_u + r_0 g,
///     K = K_uu + K_u0 g^T + g K_0u + K_00 g g^T + r_0 G,   g = dJ0/du, G = d2J0/du2,
///
/// so the assembled tangent is the exact derivative of the assembled residual.
///
/// Every kernel reads its cell data (u, fibre, activation scale, omega_a
/// Taylor data, constants) from the packed arrays of a carrier form, by name.
///
/// The three-field kernels keep theta (J0's value, DG0 "fbar_J0") and its
/// multiplier p ("fbar_pressure") as unknowns of their own: with
/// L = Pi(u, theta) + p (J0(u) - theta),
///
///     R_u = R_u(u, theta) + p g,      R_theta = r_0 - p,    R_p = J0(u) - theta,
///     K   = K_uu + p G + K_u0 g^T + g K_0u + K_00 g g^T   (theta, p condensed),
///
/// the Jacobian of (R_u, R_theta, R_p) with theta and p eliminated cell by cell
/// (FbarCellUnknowns).  They expect the packed coefficients widened by one
/// entry per cell, the cell's position in `cell_data`.
class FbarElement
{
public:
  explicit FbarElement(const forms::FbarForms& forms);

  /// R for a form on V built from `carrier`.
  CellKernel residual(const ufcx_form& carrier, const dolfinx::fem::Form<double>& form) const;
  /// K for a form on V x V.
  CellKernel jacobian(const ufcx_form& carrier, const dolfinx::fem::Form<double>& form) const;

  /// What the three-field kernels leave per cell, by position.
  struct CellData
  {
    std::size_t n = 0; ///< displacement dofs of a cell
    std::vector<double> R_theta, R_p, K00;
    std::vector<double> g, K_u0, K_0u; ///< n per cell
    void resize(std::size_t cells, std::size_t dofs);
  };
  /// R_u into A; R_theta and R_p into `cell_data`.
  CellKernel three_field_residual(const ufcx_form& carrier,
                                  const dolfinx::fem::Form<double>& form,
                                  CellData& cell_data) const;
  /// The condensed K into A; g, K_u0, K_0u, K_00 (and the residuals) into `cell_data`.
  CellKernel three_field_jacobian(const ufcx_form& carrier,
                                  const dolfinx::fem::Form<double>& form,
                                  CellData& cell_data) const;

private:
  const forms::FbarForms* _forms;
};

} // namespace muscle
