#pragma once

#include "material/ehret_uniaxial.h"

#include <map>
#include <string>

namespace muscle
{

/// Step tolerance of the activation root finders: round-off.
constexpr double default_root_tolerance = 1e-15;

/// omega_a and its derivatives with respect to the fibre stretch, at one point.
struct OmegaTaylor
{
  double value = 0; ///< omega_a
  double d1 = 0;    ///< d omega_a / d lambda
  double d2 = 0;    ///< d^2 omega_a / d lambda^2
  int iterations = 0;
  bool ok = true; ///< false: no admissible root (domain error, reported upward)
};

/// WKM (paper eq. wa): omega_a = W_0(chi*)/(alpha l^2) - I_p'/(2 l).
///
/// With y = alpha l I_p'/2 the principal-branch root W = W_0(chi*) is written as
/// W = y + z, and z = alpha l^2 omega_a solves the well-conditioned equation
///   (y + z) e^z = y + Q,   Q = (2 alpha l/gamma) P_act e^{alpha(1 - w0/l) - y},
/// on the W_0 branch (y + z >= -1), bracketed and solved by Newton.  This avoids
/// the overflow of e^y in chi* and the cancellation in W - y; the value equals
/// boost::math::lambert_w0(chi*) - y where that is representable (tested).
///
/// `level` is P_opt x time factor x element scale [kPa]; P_act = level f_xi(l).
/// omega_a = 0 when P_act = 0, as in the paper: for very short fibres
/// (y < -1) the principal branch would otherwise return a non-zero root.
/// d1 comes from the implicit-function theorem; WKM's tangent needs no d2.
///
/// `root_tolerance`: the root finder stops when its step is below this times
/// max(1, |z|) (default: round-off; a looser one saves no measurable time,
/// BENCHMARKS.md, "Root-finding tolerance of the activation kernels").
OmegaTaylor wkm_omega(double stretch, double level, const EhretParameters& p,
                      double root_tolerance = default_root_tolerance);

/// GIANT (paper eq. waimplicit, uniaxial form in ERRATA.md): with
/// m = l/(1 - omega_a) the elastic fibre stretch,
///   Psi_uni(m) = Psi_uni(l) + level int_{lambda_min}^{l} f_xi.
///
/// Root selection: the root with m >= max(1, l), i.e. omega_a in
/// [max(0, 1 - l), 1): the contractile part shortens and the elastic part is
/// stretched.  When the right-hand side's active energy is zero, omega_a = 0
/// (F_a = I), so for fibres already shorter than 1 omega_a jumps at activation
/// onset from 0 to the stretched-elastic root; this choice is deliberate
/// (ERRATA.md) and tested.  d1 and d2 come from implicit differentiation.
OmegaTaylor giant_omega(double stretch, double level, const EhretParameters& p,
                        double root_tolerance = default_root_tolerance);

/// A quadrature-point kernel: omega_a and its derivatives at one fibre stretch.
using OmegaKernel = OmegaTaylor (*)(double stretch, double level, const EhretParameters& p,
                                    double root_tolerance);

/// The quadrature-point kernels by the name a law file gives them
/// (ACTIVATION = omega_kernel("wkm", ...)).  Each registers itself where it is
/// defined, MUSCLE_OMEGA_KERNEL("name", function) in activation_kernels.cpp, and the
/// build reads the names from that file (forms/muscleforms/law.py omega_kernels):
/// a law that names no registered kernel stops the configure step.
const std::map<std::string, OmegaKernel>& omega_kernels();

/// The kernel registered as `name`; InputError "WHO: omega kernel 'NAME' is not
/// registered; registered: ..." otherwise.
OmegaKernel find_omega_kernel(const std::string& name, const std::string& who);

/// What MUSCLE_OMEGA_KERNEL calls; a name registered twice is a logic error.
bool register_omega_kernel(const char* name, OmegaKernel kernel);

} // namespace muscle

/// Registers `function` as the omega kernel `name` (a string literal).  Only in
/// activation_kernels.cpp, one a line: the build reads the names from that file.
#define MUSCLE_OMEGA_KERNEL(name, function)                                               \
  [[maybe_unused]] const bool muscle_omega_kernel_##function                              \
      = ::muscle::register_omega_kernel(name, &function)
