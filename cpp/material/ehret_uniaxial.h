#pragma once

#include <cmath>

namespace muscle
{

/// Parameters of the Ehret-type energy shared by WKM, GIANT and COMBI, plus
/// the force-stretch relation.
struct EhretParameters
{
  double alpha, beta, gamma, omega_0, lambda_min, lambda_opt;
};

/// f_xi(l) = s exp(1/2 - s^2/2), s = (l - lambda_min)/(lambda_opt - lambda_min),
/// zero for l <= lambda_min (paper eq. fxi); value, derivative and integral
/// from lambda_min.  At the kink l = lambda_min the branch l <= lambda_min
/// (zero) is taken.
struct ForceStretch
{
  double value, derivative, integral;
};

inline ForceStretch force_stretch(double l, double lambda_min,
                                  double lambda_opt)
{
  if (!(l > lambda_min))
    return {0, 0, 0};
  const double w = lambda_opt - lambda_min;
  const double s = (l - lambda_min) / w;
  const double e = std::exp(0.5 - 0.5 * s * s);
  return {s * e, (1 - s * s) * e / w,
          w * std::exp(0.5) * -std::expm1(-0.5 * s * s)};
}

/// Invariants of the incompressible uniaxial stretch F = diag(l^-1/2, l^-1/2, l)
/// along the fibre (ERRATA item 1) and their first two derivatives:
///   I_p = l^2 (1 - 2w/3) + 2w/(3l),  J_p = l^-2 (1 - 2w/3) + 2w l/3.
struct UniaxialInvariants
{
  double I, dI, d2I, J, dJ, d2J;
};

inline UniaxialInvariants uniaxial_invariants(double l, double omega_0)
{
  const double a = 1 - 2 * omega_0 / 3;
  const double b = 2 * omega_0 / 3;
  return {l * l * a + b / l,
          2 * l * a - b / (l * l),
          2 * a + 2 * b / (l * l * l),
          a / (l * l) + b * l,
          -2 * a / (l * l * l) + b,
          6 * a / (l * l * l * l)};
}

/// Uniaxial passive energy Psi(l) = gamma/4 [(e^{alpha(I_p-1)} - 1)/alpha +
/// (e^{beta(J_p-1)} - 1)/beta] and its first two derivatives.
struct UniaxialEnergy
{
  double value, d1, d2;
};

inline UniaxialEnergy uniaxial_energy(double l, const EhretParameters& p)
{
  const UniaxialInvariants u = uniaxial_invariants(l, p.omega_0);
  // I_p - 1 and J_p - 1 without cancellation near l = 1
  const double a = 1 - 2 * p.omega_0 / 3, b = 2 * p.omega_0 / 3;
  const double I_m1 = a * (l * l - 1) + b * (1 / l - 1);
  const double J_m1 = a * (1 / (l * l) - 1) + b * (l - 1);
  const double ea = std::exp(p.alpha * I_m1), eb = std::exp(p.beta * J_m1);
  const double k = p.gamma / 4;
  return {k * (std::expm1(p.alpha * I_m1) / p.alpha
               + std::expm1(p.beta * J_m1) / p.beta),
          k * (ea * u.dI + eb * u.dJ),
          k * (ea * (p.alpha * u.dI * u.dI + u.d2I)
               + eb * (p.beta * u.dJ * u.dJ + u.d2J))};
}

} // namespace muscle
