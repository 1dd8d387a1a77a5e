#pragma once

#include "material/activation_kernels.h"
#include "material/parameters.h"

#include <array>
#include <string>
#include <vector>

struct ufcx_expression;

namespace muscle
{

using Matrix3 = std::array<double, 9>;   ///< row-major 3x3
using Tangent3 = std::array<double, 81>; ///< dP_ij/dF_kl at index 27i+9j+3k+l

/// State of one material point.
struct MaterialPoint
{
  Matrix3 H{};                          ///< displacement gradient F - I
  std::array<double, 3> fibre{0, 0, 1}; ///< unit fibre direction (reference)
  double activation_scale = 1;          ///< element-wise scale of the activation
};

/// The material point with deformation gradient F (fibre e3, scale 1).
MaterialPoint point_at(const Matrix3& F);

/// A muscle model evaluated at single material points through the FFCx kernels
/// compiled from the same UFL as the finite-element forms (and, for WKM and
/// GIANT, the same quadrature-point activation kernels).
class MaterialPointModel
{
public:
  /// `kernels`: which compiled energy to use; by default the model's own
  /// ("ble", "wkm", ...).  "ble_passive" / "ehret_passive" select the passive-only
  /// forms (no activation terms at all).
  explicit MaterialPointModel(const ParameterSet& parameters,
                              std::string kernels = "");

  /// Dimensionless activation in time (1 = tetanic level, 0 = passive).
  void set_time_factor(double factor) { _time_factor = factor; }
  double time_factor() const { return _time_factor; }
  const ParameterSet& parameters() const { return _parameters; }

  double energy(const MaterialPoint& x) const;
  Matrix3 stress(const MaterialPoint& x) const;
  Tangent3 tangent(const MaterialPoint& x) const;
  double fibre_stretch(const MaterialPoint& x) const;

  /// omega_a at x from the quadrature-point kernel (zero for models without one).
  OmegaTaylor activation(const MaterialPoint& x) const;

  /// Evaluations with omega_a given instead of computed (for example frozen at
  /// another state, with derivatives set to zero).
  double energy(const MaterialPoint& x, const OmegaTaylor& omega) const;
  Matrix3 stress(const MaterialPoint& x, const OmegaTaylor& omega) const;

  /// True for WKM and GIANT, whose omega_a comes from a C++ kernel.
  bool has_activation_kernel() const;

private:
  std::vector<double> evaluate(const ufcx_expression& e, const MaterialPoint& x,
                               const OmegaTaylor& omega) const;

  ParameterSet _parameters;
  std::string _kernels;
  double _time_factor = 1;
  const void* _variant; // forms::MaterialPointVariant
};

/// Activation level passed to the kernels: P_opt x time factor x scale [kPa].
double activation_level(const ParameterSet& p, double time_factor, double scale);

/// EhretParameters of a WKM/GIANT/COMBI parameter set.
EhretParameters ehret_parameters(const ParameterSet& p);

/// The quadrature-point kernel a law names (omega_kernels()); InputError naming the
/// law file, the kernel and the registered ones if it is not registered.
OmegaKernel omega_kernel_of(const Model& model);

/// omega_a of the law's quadrature-point kernel (omega_kernel_of) at one point.
OmegaTaylor activation_kernel(const Model& model, double stretch, double level,
                              const EhretParameters& p,
                              double root_tolerance = default_root_tolerance);

} // namespace muscle
