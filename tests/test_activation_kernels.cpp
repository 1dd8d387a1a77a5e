// The quadrature-point activation kernels of WKM and GIANT against independent
// maths: the paper's closed Lambert-W formula (Boost), the defining uniaxial
// equations, and finite differences of the kernels' own values.
#include "support/finite_differences.h"

#include <material/activation_kernels.h>
#include <material/material_point.h>
#include <material/parameters.h>

#include <boost/math/special_functions/lambert_w.hpp>
#include <cmath>
#include <gtest/gtest.h>

using namespace muscle;

namespace
{
EhretParameters fitted()
{
  return ehret_parameters(ParameterSet(Model("wkm")));
}

// The paper's eq. wa verbatim (with ERRATA's I_p'), through Boost's W_0.
double paper_wkm_omega(double l, double P_act, const EhretParameters& p)
{
  const UniaxialInvariants u = uniaxial_invariants(l, p.omega_0);
  const double chi
      = P_act * 2 * p.alpha * l / p.gamma
            * std::exp(p.alpha / 2 * (2 - 2 * u.I + l * u.dI))
        + p.alpha / 2 * l * u.dI * std::exp(p.alpha / 2 * l * u.dI);
  return boost::math::lambert_w0(chi) / (p.alpha * l * l) - u.dI / (2 * l);
}

// Uniaxial nominal stress of WKM with omega_a held fixed (dPsi/dl).
double wkm_uniaxial_stress(double l, double omega, const EhretParameters& p)
{
  const UniaxialInvariants u = uniaxial_invariants(l, p.omega_0);
  return p.gamma / 4
         * (std::exp(p.alpha * (u.I + omega * l * l - 1)) * (u.dI + 2 * omega * l)
            + std::exp(p.beta * (u.J - 1)) * u.dJ);
}

} // namespace

TEST(WkmKernel, MatchesPaperLambertWFormula)
{
  const EhretParameters p = fitted();
  for (double level : {1.0, 64.68, 200.0})
    for (double l = 0.6; l <= 1.8; l += 0.05)
    {
      const double P_act = level * force_stretch(l, p.lambda_min, p.lambda_opt).value;
      const OmegaTaylor w = wkm_omega(l, level, p);
      ASSERT_TRUE(w.ok);
      EXPECT_NEAR(w.value, paper_wkm_omega(l, P_act, p),
                  1e-10 * std::max(1.0, std::abs(w.value)))
          << "l=" << l << " level=" << level;
    }
}

TEST(WkmKernel, UniaxialStressIsPassivePlusActive)
{
  // the two assumptions that define omega_a in WKM (paper section GASA)
  const EhretParameters p = fitted();
  const double level = 64.68;
  for (double l = 0.6; l <= 1.8; l += 0.1)
  {
    const OmegaTaylor w = wkm_omega(l, level, p);
    const double P_act = level * force_stretch(l, p.lambda_min, p.lambda_opt).value;
    EXPECT_NEAR(wkm_uniaxial_stress(l, w.value, p),
                wkm_uniaxial_stress(l, 0, p) + P_act, 1e-10 * (1 + P_act));
  }
}

TEST(WkmKernel, DerivativeFromImplicitFunctionTheorem)
{
  const EhretParameters p = fitted();
  for (double l : {0.6, 0.75, 1.0, 1.2, 1.5, 1.8})
  {
    const double fd = muscle::testing::central_at([&](double s) { return wkm_omega(s, 64.68, p).value; },
                                 l, 1e-4);
    EXPECT_NEAR(wkm_omega(l, 64.68, p).d1, fd, 1e-8 * std::max(1.0, std::abs(fd)))
        << "l=" << l;
  }
}

TEST(WkmKernel, ZeroActiveStressGivesZeroOmega)
{
  const EhretParameters p = fitted();
  for (double l : {0.3, 0.5, p.lambda_min, 1.0, 1.5})
  {
    EXPECT_EQ(wkm_omega(l, 0.0, p).value, 0.0);
    EXPECT_EQ(wkm_omega(l, 0.0, p).d1, 0.0);
  }
  // below lambda_min f_xi vanishes: omega_a = 0 even when activated
  EXPECT_EQ(wkm_omega(0.5, 64.68, p).value, 0.0);
}

TEST(WkmKernel, NoOverflowWhereTheClosedFormOverflows)
{
  // alpha = 60 makes e^y in chi* overflow at l = 3; the z-form stays finite and
  // still satisfies the defining equation.
  EhretParameters p = fitted();
  p.alpha = 60;
  const double l = 3.0, level = 50;
  const OmegaTaylor w = wkm_omega(l, level, p);
  ASSERT_TRUE(w.ok);
  EXPECT_GE(w.value, 0);
  const double P_act = level * force_stretch(l, p.lambda_min, p.lambda_opt).value;
  const double lhs = wkm_uniaxial_stress(l, w.value, p);
  const double rhs = wkm_uniaxial_stress(l, 0, p) + P_act;
  EXPECT_NEAR(lhs / rhs, 1.0, 1e-12);
}

namespace
{
double uniaxial_psi(double m, const EhretParameters& p)
{
  return uniaxial_energy(m, p).value;
}
} // namespace

TEST(GiantKernel, SolvesTheImplicitEquation)
{
  const EhretParameters p = fitted();
  for (double level : {1.0, 64.68, 300.0})
    for (double l = 0.6; l <= 1.8; l += 0.05)
    {
      const OmegaTaylor w = giant_omega(l, level, p);
      ASSERT_TRUE(w.ok);
      const double A = level * force_stretch(l, p.lambda_min, p.lambda_opt).integral;
      const double m = l / (1 - w.value);
      EXPECT_NEAR(uniaxial_psi(m, p), uniaxial_psi(l, p) + A,
                  1e-11 * (1 + uniaxial_psi(m, p)))
          << "l=" << l << " level=" << level;
      EXPECT_LE(w.iterations, 12) << "Newton should converge in a few steps";
    }
}

// The root tolerance is a knob: a loose one still returns an admissible root,
// and the error in omega_a stays within what the tolerance allows (the step
// bound times a few, Newton being quadratic at the end) -- measured against the
// round-off root, not against itself.
TEST(GiantKernel, LooseRootToleranceStaysWithinIt)
{
  const EhretParameters p = fitted();
  for (double tolerance : {1e-10, 1e-6, 1e-3})
  {
    int saved = 0;
    for (double l = 0.7; l <= 1.6; l += 0.1)
    {
      const OmegaTaylor exact = giant_omega(l, 64.68, p);
      const OmegaTaylor loose = giant_omega(l, 64.68, p, tolerance);
      ASSERT_TRUE(loose.ok);
      EXPECT_LE(loose.iterations, exact.iterations);
      saved += exact.iterations - loose.iterations;
      // omega = d/(l + d): |d omega| <= |d d| / l
      EXPECT_NEAR(loose.value, exact.value, 10 * tolerance * std::max(1.0, 1 / l))
          << "l=" << l << " tolerance=" << tolerance;
    }
    if (tolerance == 1e-3)
      EXPECT_GT(saved, 0) << "a loose tolerance must stop the root finder earlier";
  }
}

TEST(GiantKernel, DerivativesFromImplicitDifferentiation)
{
  const EhretParameters p = fitted();
  for (double l : {0.6, 0.8, 1.0, 1.1806, 1.4, 1.8})
  {
    auto value = [&](double s) { return giant_omega(s, 64.68, p).value; };
    auto slope = [&](double s) { return giant_omega(s, 64.68, p).d1; };
    const OmegaTaylor w = giant_omega(l, 64.68, p);
    const double d1 = muscle::testing::central_at(value, l, 1e-4);
    const double d2 = muscle::testing::central_at(slope, l, 1e-4);
    EXPECT_NEAR(w.d1, d1, 1e-7 * std::max(1.0, std::abs(d1))) << "l=" << l;
    EXPECT_NEAR(w.d2, d2, 1e-6 * std::max(1.0, std::abs(d2))) << "l=" << l;
  }
}

TEST(GiantKernel, RootSelectionStretchesTheElasticPart)
{
  // omega_a lies in [max(0, 1 - l), 1): elastic fibre stretch m >= max(1, l)
  const EhretParameters p = fitted();
  for (double l = 0.6; l <= 1.8; l += 0.1)
  {
    const OmegaTaylor w = giant_omega(l, 10.0, p);
    EXPECT_GE(w.value, std::max(0.0, 1 - l) - 1e-15) << "l=" << l;
    EXPECT_LT(w.value, 1.0);
  }
  // activation onset for a fibre already at l = 0.8: omega_a jumps from 0 to
  // (nearly) the mirrored root with Psi(m) = Psi(l), the deliberate choice
  const double l = 0.8;
  EXPECT_EQ(giant_omega(l, 0.0, p).value, 0.0);
  const OmegaTaylor onset = giant_omega(l, 1e-9, p);
  const double m = l / (1 - onset.value);
  EXPECT_GT(m, 1.0);
  EXPECT_NEAR(uniaxial_psi(m, p), uniaxial_psi(l, p), 1e-8);
}

TEST(GiantKernel, SmallActivationWithoutCancellation)
{
  // omega_a ~ A / (l Psi'(l)) for small A: relative accuracy must survive
  const EhretParameters p = fitted();
  const double l = 1.3, level = 1e-9;
  const double A = level * force_stretch(l, p.lambda_min, p.lambda_opt).integral;
  const double first_order = A / (l * uniaxial_energy(l, p).d1);
  EXPECT_NEAR(giant_omega(l, level, p).value / first_order, 1.0, 1e-6);
}
