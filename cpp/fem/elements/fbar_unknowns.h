#pragma once

#include "fem/elements/fbar_element.h"

#include <dolfinx/fem/DirichletBC.h>
#include <dolfinx/la/Vector.h>
#include <memory>
#include <petscmat.h>
#include <span>
#include <vector>

namespace muscle
{
class MuscleProblem;

/// The cell unknowns of the three-field F-bar element on one part of a body:
/// theta (the cell's volume ratio, J0's value) and its multiplier p, two per
/// owned cell of the part, next to the displacement in the Newton vector.
///
/// Why: with J0(u) inside the energy, a Newton step evaluates the stiff penalty
/// at J0(u + du), whose error is quadratic in du -- for the preset
/// incompressibility (det(C)^-1000) that error alone makes most full steps
/// fail.  With theta as an unknown the penalty sees theta + dtheta, linear in
/// the step, and the constraint J0(u) = theta is met by the multiplier.  The
/// converged states are the same as the displacement F-bar's.
///
/// theta and p are eliminated cell by cell from every Newton system: the
/// displacement block is the F-bar tangent (with p for r_0), the right-hand
/// side gains each cell's condensed terms, and dtheta, dp follow from du.
/// Dirichlet dofs get identity rows and keep their columns: the residual is
/// not lifted, so the Newton matrix is its true derivative even while a damped
/// step leaves the boundary values unmet (lifting assumes they are met, and
/// the stiff penalty makes that error large).
class FbarCellUnknowns
{
public:
  FbarCellUnknowns(MuscleProblem& part,
                   const std::vector<std::shared_ptr<const dolfinx::fem::DirichletBC<double>>>& bcs);
  // the forms' kernels write into this object's cell data
  FbarCellUnknowns(const FbarCellUnknowns&) = delete;
  FbarCellUnknowns& operator=(const FbarCellUnknowns&) = delete;

  /// Entries in the solver vector: (theta, p) per owned cell of the part.
  std::int32_t size() const { return 2 * static_cast<std::int32_t>(_cells.size()); }

  /// theta = J0(u) and p = r_0(u, theta): the consistent start of a solve
  /// (u and the activation kernels current).
  void initialise();
  /// theta, p from / into this part's block of the solver vector.
  void set(std::span<const double> x);
  void get(std::span<double> x) const;

  /// R_u added into b (unrolled, owned and ghost entries; not scattered),
  /// (R_theta, R_p) into r.  Returns the largest |R_p| (constraint violation).
  double residual(std::span<double> b, std::span<double> r);
  /// The condensed tangent added into A (blocked, Dirichlet rows zeroed);
  /// stores each cell's linearisation for the calls below.
  void jacobian(Mat A);
  /// Whether the stored linearisation (and residual) is finite everywhere.
  bool linearisation_is_finite() const;

  /// Condensation of a right-hand side (b_u, b_cells): b_u += the cells' terms
  /// (unrolled, owned and ghost; scatter_rev afterwards).
  void condense(std::span<const double> b_cells, std::span<double> b_u) const;
  /// (dtheta, dp) from du (unrolled, owned and ghost, Dirichlet part included)
  /// and b_cells.
  void recover(std::span<const double> du, std::span<const double> b_cells,
               std::span<double> d_cells) const;
  /// The extended Jacobian times (du, d_cells): the cells' rows into y_cells,
  /// and what the u-rows add to K du into y_u (unrolled; scatter_rev afterwards).
  void multiply(std::span<const double> du, std::span<const double> d_cells,
                std::span<double> y_u, std::span<double> y_cells) const;

  /// The stored linearisation and where it acts (the penalty-split preconditioner):
  /// cell i's displacement dofs are cell_dofs()[i n .. (i + 1) n) (unrolled, owned
  /// and ghost), fixed() marks the Dirichlet ones.
  const FbarElement::CellData& linearisation() const { return _data; }
  std::span<const std::int32_t> cell_dofs() const { return _cell_dofs; }
  std::span<const std::int8_t> fixed() const { return _fixed; }

private:
  std::vector<double> widened_coefficients(const dolfinx::fem::Form<double>& form) const;
  /// a . du over all the cell's dofs
  double dot(std::size_t cell, const std::vector<double>& a, std::span<const double> du) const;

  MuscleProblem& _part;
  std::vector<std::shared_ptr<const dolfinx::fem::DirichletBC<double>>> _bcs;
  FbarElement::CellData _data;
  std::shared_ptr<dolfinx::fem::Form<double>> _residual, _jacobian;
  std::vector<std::int32_t> _cells;      ///< the part's owned cells, in integral order
  std::vector<std::int32_t> _cell_dofs;  ///< unrolled displacement dofs, n per cell
  std::vector<std::int32_t> _theta_dofs; ///< DG0 dof of each cell
  std::vector<std::int8_t> _fixed;       ///< Dirichlet marker of the unrolled dofs
};

} // namespace muscle
