#pragma once

#include "material/activation_kernels.h"
#include "fem/elements/fbar_element.h"
#include "material/parameters.h"

#include <array>
#include <dolfinx/fem/Constant.h>
#include <dolfinx/fem/Expression.h>
#include <dolfinx/fem/Form.h>
#include <dolfinx/fem/Function.h>
#include <dolfinx/fem/FunctionSpace.h>
#include <dolfinx/mesh/Mesh.h>
#include <functional>
#include <map>
#include <optional>
#include <memory>
#include <string>
#include <vector>

namespace muscle
{
namespace forms
{
struct FeVariant;
}

/// Element choice of a discretisation.
struct Discretisation
{
  int degree = 1;             ///< Lagrange degree of the displacement
  int quadrature_degree = -1; ///< -1: the default for the element
  /// rule of the stiff volumetric part; -1: quadrature_degree.  1 on Q1 is the
  /// anti-locking choice (selective reduced integration).
  int volumetric_quadrature_degree = -1;
  /// F-bar hexahedron (Q1): the energy at F_bar = (J0/J)^(1/3) F, J0 = det F at
  /// the cell centre -- the paper's locking-free element, for every model.
  bool fbar = false;
  /// Taylor-Hood (degree 2): the energy at F_bar = (theta/J)^(1/3) F with the
  /// volume ratio theta and its multiplier p continuous of degree 1, unknowns of
  /// the Newton system next to u (forms/muscleforms/taylor_hood.py).
  bool taylor_hood = false;
};

/// Outcome of evaluating the quadrature-point activation kernels.
struct KernelStatus
{
  std::int64_t failures = 0;  ///< points without an admissible root
  std::int32_t worst_cell = -1; ///< a local cell where it failed
  double stretch = 0;         ///< fibre stretch there
  bool ok() const { return failures == 0; }
};

/// The cells a part of a body occupies: those of `tags` with `value`.
struct CellRegion
{
  std::shared_ptr<const dolfinx::mesh::MeshTags<std::int32_t>> tags;
  int value = 0;
};

/// One muscle body: displacement space, material forms (residual, Jacobian,
/// volume), fibre and activation-scale fields, and -- for WKM and GIANT -- the
/// quadrature-point activation kernel that feeds omega_a to the forms.
///
/// Only what the material needs is built: a passive body uses the passive-only
/// forms (no activation terms, no kernel), BLE and COMBI never call a kernel.
class MuscleProblem
{
public:
  /// `passive`: build the passive-only forms (ble_passive / ehret_passive).
  /// A part of a body of several materials gives its `region` (the forms,
  /// kernels and post-processing see only those cells) and the displacement
  /// `u` it shares with the other parts (same element).
  MuscleProblem(std::shared_ptr<dolfinx::mesh::Mesh> mesh,
                const ParameterSet& parameters, Discretisation discretisation,
                bool passive = false, std::optional<CellRegion> region = std::nullopt,
                std::shared_ptr<dolfinx::fem::Function<double>> u = nullptr);

  const ParameterSet& parameters() const { return _parameters; }
  bool passive() const { return _passive; }
  const std::string& kernel_name() const { return _kernels; }
  int quadrature_degree() const;
  /// The stiff volumetric part on a rule of its own (the anti-locking Q1).
  bool reduced_volumetric() const;

  std::shared_ptr<dolfinx::mesh::Mesh> mesh() const { return _mesh; }
  std::shared_ptr<dolfinx::fem::FunctionSpace> V() const { return _V; }
  std::shared_ptr<dolfinx::fem::Function<double>> u() const { return _u; }
  /// Element-wise unit fibre direction (DG0 vector).
  std::shared_ptr<dolfinx::fem::Function<double>> fibre() const { return _fibre; }
  /// Element-wise scale of the activation (DG0), 1 by default.
  std::shared_ptr<dolfinx::fem::Function<double>> activation_scale() const
  {
    return _scale;
  }

  /// Same fibre direction everywhere (normalised here).
  void set_fibre(std::array<double, 3> direction);

  /// Dimensionless activation in time (1: tetanic level).
  void set_time_factor(double factor);
  double time_factor() const { return _time_factor; }

  /// Update omega_a at every quadrature point from the current u (WKM, GIANT);
  /// a no-op for the other models.
  KernelStatus update_activation();
  bool has_activation_kernel() const { return !_taylor.empty(); }
  /// Step tolerance of the activation root finder (relative; default round-off).
  void set_root_tolerance(double tolerance) { _root_tolerance = tolerance; }

  std::shared_ptr<const dolfinx::fem::Form<double>> residual() const { return _residual; }
  std::shared_ptr<const dolfinx::fem::Form<double>> jacobian() const { return _jacobian; }
  /// F-bar hexahedra (Discretisation::fbar).
  bool fbar() const { return _fbar != nullptr; }

  /// Three-field F-bar (FbarCellUnknowns): theta = "fbar_J0" and its
  /// multiplier p as DG0 fields, read by every F-bar kernel and expression.
  std::shared_ptr<dolfinx::fem::Function<double>> fbar_theta() const { return _fbar_J0; }
  std::shared_ptr<dolfinx::fem::Function<double>> fbar_pressure() const
  {
    return _fbar_pressure;
  }
  /// While held, update_activation() leaves theta to the solver instead of
  /// setting it to J0(u).
  void hold_fbar_theta(bool hold) { _hold_theta = hold; }
  /// theta = J0(u) on every local cell.
  void reset_fbar_theta() const;
  /// The three-field kernels as forms on V (residual) and V x V (jacobian),
  /// writing their per-cell results into `data`; they expect packed
  /// coefficients widened by the cell's position (FbarElement).
  std::shared_ptr<dolfinx::fem::Form<double>>
  fbar_three_field_form(bool jacobian, FbarElement::CellData& data) const;

  /// Taylor-Hood elements (Discretisation::taylor_hood).
  bool taylor_hood() const { return _th_state != nullptr; }
  /// Taylor-Hood: q = (theta, p), the degree-1 field of two components the
  /// forms read, and the blocks of the Newton system besides residual() and
  /// jacobian() (R_q, dR_u/dq, dR_q/du, dR_q/dq).
  std::shared_ptr<dolfinx::fem::Function<double>> th_state() const { return _th_state; }
  struct TaylorHoodForms
  {
    std::shared_ptr<const dolfinx::fem::Form<double>> residual, jacobian_uq, jacobian_qu,
        jacobian_qq;
  };
  const TaylorHoodForms& th_forms() const { return _th_forms; }
  /// theta = 1, p = 0: the reference state's (theta, p) of a law without prestress.
  void reset_th_state();

  /// The residual assembled over the cells tagged `value` only (same kernel):
  /// summing it over the nodes of an interface gives the force the rest of the
  /// body transmits through it, the variationally consistent section force.
  /// (A part of a body: tag only cells of its region with `value`.)
  std::shared_ptr<dolfinx::fem::Form<double>>
  residual_on_cells(std::shared_ptr<const dolfinx::mesh::MeshTags<std::int32_t>> cells,
                    int value) const;

  /// Copy an element-wise fibre field (same DG0 vector space as fibre()).
  void set_fibre(const dolfinx::fem::Function<double>& fibre);

  /// Current volume of the body.
  double volume() const;
  /// Strain energy of the body at the current displacement and activation
  /// (µJ = mN mm; collective).
  double strain_energy() const;

  /// Local cells (owned and ghost) this problem integrates over.
  const std::vector<std::int32_t>& cells() const { return _cells; }

  /// Cell averages (reference quadrature weights) of the fibre stretch,
  /// Cauchy fibre stress sigma_m, von Mises stress, J and von Mises strain
  /// (of the Green-Lagrange strain), as DG0 functions (zero outside the
  /// problem's cells).
  struct PostFields
  {
    std::shared_ptr<dolfinx::fem::Function<double>> fibre_stretch, fibre_stress,
        von_mises, J, von_mises_strain;
    /// all of them, in the order above
    std::array<std::shared_ptr<dolfinx::fem::Function<double>>, 5> all() const
    {
      return {fibre_stretch, fibre_stress, von_mises, J, von_mises_strain};
    }
  };
  PostFields post_fields() const;

  /// Smallest J over all quadrature points of the local cells, and where.
  std::pair<double, std::int32_t> min_jacobian_determinant() const;

  /// DG0 scalar space on this mesh.
  std::shared_ptr<dolfinx::fem::FunctionSpace> cell_space(int block_size = 1) const;

private:
  std::shared_ptr<dolfinx::mesh::Mesh> _mesh;
  ParameterSet _parameters;
  bool _passive;
  std::string _kernels;
  const forms::FeVariant* _variant;
  double _time_factor = 0;
  double _root_tolerance = default_root_tolerance;

  std::shared_ptr<dolfinx::fem::FunctionSpace> _V;
  std::shared_ptr<dolfinx::fem::Function<double>> _u, _fibre, _scale;
  std::map<std::string, std::shared_ptr<dolfinx::fem::Function<double>>> _taylor;
  std::map<std::string, std::shared_ptr<dolfinx::fem::Constant<double>>> _constants;
  std::shared_ptr<dolfinx::fem::Form<double>> _residual, _jacobian, _volume, _energy;
  /// A functional summed over the ranks.
  double sum_over_ranks(const dolfinx::fem::Form<double>& functional) const;
  /// the residual's cell kernel (with the volumetric part on its own rule)
  std::function<void(double*, const double*, const double*, const double*, const int*,
                     const std::uint8_t*)>
      _residual_kernel;
  std::shared_ptr<dolfinx::fem::Expression<double>> _stretch_expression, _post_expression;
  /// F-bar: the kernels, J0 at the cell centres (read by the expressions) and
  /// the expression that computes it
  std::shared_ptr<const FbarElement> _fbar;
  std::shared_ptr<dolfinx::fem::Function<double>> _fbar_J0, _fbar_pressure;
  bool _hold_theta = false;
  std::shared_ptr<dolfinx::fem::Function<double>> _th_state;
  TaylorHoodForms _th_forms;
  std::shared_ptr<dolfinx::fem::Expression<double>> _centre_dilatation;
  void update_centre_dilatation() const;
  std::vector<double> _quadrature_weights;
  std::vector<std::int32_t> _cells, _owned_cells;
  std::optional<CellRegion> _region;
};

} // namespace muscle
