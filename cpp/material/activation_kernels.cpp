#include "material/activation_kernels.h"

#include "common/errors.h"
#include "material/root_finding.h"

#include <algorithm>
#include <boost/math/special_functions/lambert_w.hpp>
#include <cmath>
#include <stdexcept>
#include <utility>
#include <vector>

namespace muscle
{
namespace
{
std::map<std::string, OmegaKernel>& registry()
{
  static std::map<std::string, OmegaKernel> kernels;
  return kernels;
}
} // namespace

const std::map<std::string, OmegaKernel>& omega_kernels()
{
  return registry();
}

OmegaKernel find_omega_kernel(const std::string& name, const std::string& who)
{
  if (auto it = registry().find(name); it != registry().end())
    return it->second;
  std::vector<std::string> names;
  for (const auto& [k, _] : registry())
    names.push_back(k);
  throw InputError(who + ": omega kernel '" + name + "' is not registered; registered: "
                   + join(names) + " (MUSCLE_OMEGA_KERNEL in cpp/material/activation_kernels.cpp)");
}

bool register_omega_kernel(const char* name, OmegaKernel kernel)
{
  if (!registry().emplace(name, kernel).second)
    throw std::logic_error(std::string("omega kernel '") + name + "' registered twice");
  return true;
}

OmegaTaylor wkm_omega(double l, double level, const EhretParameters& p,
                      double root_tolerance)
{
  OmegaTaylor r;
  const ForceStretch fs = force_stretch(l, p.lambda_min, p.lambda_opt);
  const double P_act = level * fs.value;
  if (!(P_act > 0))
    return r;

  const UniaxialInvariants u = uniaxial_invariants(l, p.omega_0);
  const double y = 0.5 * p.alpha * l * u.dI;
  const double dy = 0.5 * p.alpha * (u.dI + l * u.d2I);
  // chi* = e^y (y + Q): the exponent alpha/2 (2 - 2 I_p + l I_p') = alpha (1 - w0/l)
  const double e = std::exp(p.alpha * (1 - p.omega_0 / l) - y);
  const double k = 2 * p.alpha / p.gamma;
  const double Q = k * l * P_act * e;
  const double dP_act = level * fs.derivative;
  const double dQ = k * e
                    * (P_act + l * dP_act
                       + l * P_act * (p.alpha * p.omega_0 / (l * l) - dy));
  if (!std::isfinite(Q) or !std::isfinite(dQ))
  {
    r.ok = false;
    return r;
  }

  // F(z) = (y + z) e^z - y - Q, written without cancellation for small z
  auto F = [&](double z)
  {
    const double ez = std::exp(z);
    return std::pair{y * std::expm1(z) + z * ez - Q, (1 + y + z) * ez};
  };
  const double lo = std::max(0.0, -1 - y); // W_0 branch: W = y + z >= -1
  double hi = lo + 1;
  for (int i = 0; i < 64 and F(hi).first < 0; ++i)
    hi = 2 * hi + 1;

  // Start from Boost's W_0 where chi* is representable; Newton polishes z.
  double z0 = 0.5 * (lo + hi);
  if (y < 600)
  {
    const double chi = std::max(std::exp(y) * (y + Q), -std::exp(-1.0));
    if (std::isfinite(chi))
      z0 = boost::math::lambert_w0(chi) - y;
  }
  const RootResult root = bracketed_newton(F, lo, hi, z0, root_tolerance);
  const double z = root.x;
  r.iterations = root.iterations;

  const double ez = std::exp(z);
  const double Fz = (1 + y + z) * ez;
  const double Fl = dy * std::expm1(z) - dQ;
  if (!root.converged or !(Fz > 0))
  {
    r.ok = false; // at the branch point W = -1 the derivative is unbounded
    return r;
  }
  const double dz = -Fl / Fz;
  const double a = p.alpha * l * l;
  r.value = z / a;
  r.d1 = dz / a - 2 * z / (a * l);
  r.ok = std::isfinite(r.value) and std::isfinite(r.d1);
  return r;
}
MUSCLE_OMEGA_KERNEL("wkm", wkm_omega);

namespace
{
/// Psi_uni(l + d) - Psi_uni(l) and its derivative in d, without the
/// cancellation of subtracting two energies (matters for small activation).
std::pair<double, double> uniaxial_energy_increment(double l, double d,
                                                    const EhretParameters& p)
{
  const double a = 1 - 2 * p.omega_0 / 3, b = 2 * p.omega_0 / 3;
  const double m = l + d;
  const double I_l_m1 = a * (l * l - 1) + b * (1 / l - 1);
  const double J_l_m1 = a * (1 / (l * l) - 1) + b * (l - 1);
  const double dI = d * (a * (2 * l + d) - b / (l * m));
  const double dJ = d * (b - a * (2 * l + d) / (l * l * m * m));
  const double k = p.gamma / 4;
  const double value
      = k * (std::exp(p.alpha * I_l_m1) * std::expm1(p.alpha * dI) / p.alpha
             + std::exp(p.beta * J_l_m1) * std::expm1(p.beta * dJ) / p.beta);
  return {value, uniaxial_energy(m, p).d1};
}
} // namespace

OmegaTaylor giant_omega(double l, double level, const EhretParameters& p,
                        double root_tolerance)
{
  OmegaTaylor r;
  const ForceStretch fs = force_stretch(l, p.lambda_min, p.lambda_opt);
  const double A = level * fs.integral;
  if (!(A > 0))
    return r;

  // unknown d = m - l >= max(0, 1 - l), so that m = l + d >= max(1, l)
  auto g = [&](double d)
  {
    const auto [dpsi, dpsi_dd] = uniaxial_energy_increment(l, d, p);
    return std::pair{dpsi - A, dpsi_dd};
  };
  const double lo = std::max(0.0, 1 - l);
  double hi = std::max(2 * lo, 0.5);
  for (int i = 0; i < 64 and g(hi).first < 0; ++i)
    hi = 2 * hi + 1;

  // quadratic model of g at lo as a first guess
  const auto [g0, dg0] = g(lo);
  const double curvature = uniaxial_energy(l + lo, p).d2;
  double d0 = lo;
  if (curvature > 0)
    d0 = lo
         + (-dg0 + std::sqrt(std::max(0.0, dg0 * dg0 - 2 * curvature * g0)))
               / curvature;

  const RootResult root = bracketed_newton(g, lo, hi, d0, root_tolerance);
  r.iterations = root.iterations;
  const double d = root.x;
  const double m = l + d;
  const UniaxialEnergy at_l = uniaxial_energy(l, p), at_m = uniaxial_energy(m, p);
  if (!root.converged or !(at_m.d1 > 0))
  {
    r.ok = false;
    return r;
  }
  // implicit differentiation of Psi(m(l)) = Psi(l) + A(l)
  const double A1 = level * fs.value, A2 = level * fs.derivative;
  const double m1 = (at_l.d1 + A1) / at_m.d1;
  const double m2 = (at_l.d2 + A2 - at_m.d2 * m1 * m1) / at_m.d1;
  r.value = d / m;
  r.d1 = -1 / m + l * m1 / (m * m);
  r.d2 = 2 * m1 / (m * m) - 2 * l * m1 * m1 / (m * m * m) + l * m2 / (m * m);
  r.ok = std::isfinite(r.value) and std::isfinite(r.d1) and std::isfinite(r.d2);
  return r;
}
MUSCLE_OMEGA_KERNEL("giant", giant_omega);

} // namespace muscle
