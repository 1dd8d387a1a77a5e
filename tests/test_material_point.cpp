// Point-wise consistency of the compiled models: stress against central
// differences of the energy, tangent against central differences of the
// stress, over fibre stretch 0.5 - 1.8 and shear up to 0.5, all models, active
// and passive; BLE's zero-shear state without any epsilon shift.
#include <loadcases/load_case.h>
#include <material/material_point.h>

#include <cmath>
#include <gtest/gtest.h>
#include <support/tensors.h>
#include <random>

using namespace muscle;
using namespace muscle::testing;

namespace
{
/// States: uniaxial fibre stretch l times a random shear, scaled to J = 1 + delta.
std::vector<MaterialPoint> random_states(std::mt19937& rng, int count)
{
  std::uniform_real_distribution<double> stretch(0.5, 1.8), shear(-0.5, 0.5),
      dilatation(-1e-3, 1e-3);
  std::vector<MaterialPoint> states;
  for (int n = 0; n < count; ++n)
  {
    const double l = stretch(rng);
    const Matrix3 U = {1 / std::sqrt(l), 0, 0, 0, 1 / std::sqrt(l), 0, 0, 0, l};
    Matrix3 S = {1, shear(rng), shear(rng), shear(rng), 1, shear(rng),
                 shear(rng), shear(rng), 1};
    Matrix3 F = multiply(S, U);
    const double scale = std::cbrt((1 + dilatation(rng)) / det(F));
    MaterialPoint x;
    for (int i = 0; i < 9; ++i)
      x.H[i] = scale * F[i] - (i % 4 == 0 ? 1.0 : 0.0);
    states.push_back(x);
  }
  return states;
}

void check_model(const Model& model, MuscleState state, int seed)
{
  MaterialPointModel m{ParameterSet(model)};
  m.set_time_factor(state == MuscleState::active ? 1.0 : 0.0);
  std::mt19937 rng(seed);
  const double h = 1e-5;
  int checked = 0;
  for (const MaterialPoint& x : random_states(rng, 40))
  {
    if (near_switch(m, x, 50 * h))
      continue;
    ++checked;
    // WKM's stress holds omega_a fixed (paper eq. S_WKM): differentiate the
    // energy with omega_a frozen at its value in x.
    OmegaTaylor frozen = m.activation(x);
    frozen.d1 = frozen.d2 = 0;
    const Matrix3 P = m.stress(x);
    const Tangent3 A = m.tangent(x);
    double P_scale = 1, A_scale = 1;
    for (double v : P)
      P_scale = std::max(P_scale, std::abs(v));
    for (double v : A)
      A_scale = std::max(A_scale, std::abs(v));

    for (int k = 0; k < 9; ++k)
    {
      auto shifted = [&](double d)
      {
        MaterialPoint y = x;
        y.H[k] += d;
        return y;
      };
      const double dpsi = central(
          [&](double d)
          {
            return model.law().stress_holds_omega ? m.energy(shifted(d), frozen)
                                                  : m.energy(shifted(d));
          },
          h);
      EXPECT_NEAR(P[k], dpsi, 1e-6 * P_scale)
          << to_string(model) << " " << to_string(state) << " P[" << k << "]";
      for (int ij = 0; ij < 9; ++ij)
      {
        const double dP
            = central([&](double d) { return m.stress(shifted(d))[ij]; }, h);
        EXPECT_NEAR(A[9 * ij + k], dP, 1e-6 * A_scale)
            << to_string(model) << " " << to_string(state) << " A[" << ij << ","
            << k << "]";
      }
    }
  }
  EXPECT_GT(checked, 30);
}
} // namespace

// every law of the registry, users' laws (MUSCLE_MATERIALS) included
TEST(MaterialPoint, StressAndTangentMatchFiniteDifferences)
{
  int seed = 7;
  for (const Model& model : all_models())
  {
    for (MuscleState state : {MuscleState::passive, MuscleState::active})
      check_model(model, state, seed);
    ++seed;
  }
}

TEST(MaterialPoint, ReferenceStateIsStressFree)
{
  for (const Model& model : all_models())
  {
    MaterialPointModel m{ParameterSet(model)};
    m.set_time_factor(0);
    const MaterialPoint x; // H = 0
    EXPECT_NEAR(m.energy(x), 0.0, 1e-14) << to_string(model);
    for (double v : m.stress(x))
      EXPECT_NEAR(v, 0.0, 1e-12) << to_string(model);
    for (double v : m.tangent(x))
      EXPECT_TRUE(std::isfinite(v)) << to_string(model);
  }
}

TEST(MaterialPoint, BlePassiveSwitchIsExactAtTheReferenceState)
{
  // f_passive switches on at fibre stretch 1 -- the undeformed state.  The
  // paper's definition puts lambda = 1 on the zero branch; a fibre vector whose
  // length is 1 +- 1e-16 must not flip it (ERRATA, "numerical trap").
  ParameterSet without_passive_fibre(Model("ble"));
  without_passive_fibre.set("P1", 0);
  MaterialPointModel ble{ParameterSet(Model("ble"))}, reference{without_passive_fibre};
  for (const auto& fibre : {std::array<double, 3>{0, 0, 1},
                            std::array<double, 3>{0.6, 0, 0.8},
                            std::array<double, 3>{1 / std::sqrt(3.0), 1 / std::sqrt(3.0),
                                                  1 / std::sqrt(3.0)}})
  {
    MaterialPoint x;
    x.fibre = fibre;
    const Tangent3 A = ble.tangent(x), A0 = reference.tangent(x);
    for (int i = 0; i < 81; ++i)
      EXPECT_EQ(A[i], A0[i]) << "component " << i;
  }
}

TEST(MaterialPoint, BleZeroShearNeedsNoEpsilonShift)
{
  // Pure fibre stretch has theta = 1 exactly: the paper's A_2 is 0/0 there.
  // The series evaluation must give finite stress and tangent that agree with
  // the neighbouring sheared states and with finite differences.
  MaterialPointModel m{ParameterSet(Model("ble"))};
  for (double l : {0.7, 1.0, 1.3})
  {
    MaterialPoint x;
    x.H = {1 / std::sqrt(l) - 1, 0, 0, 0, 1 / std::sqrt(l) - 1, 0, 0, 0, l - 1};
    const Tangent3 A = m.tangent(x);
    for (double v : A)
      ASSERT_TRUE(std::isfinite(v)) << "l=" << l;
    // transverse shear stiffness: d P_12 / d H_12 against finite differences
    const double h = 1e-6;
    const double fd = central(
        [&](double d)
        {
          MaterialPoint y = x;
          y.H[1] += d;
          return m.stress(y)[1];
        },
        h);
    EXPECT_NEAR(A[9 * 1 + 1], fd, 1e-6 * std::abs(fd)) << "l=" << l;
  }
}

TEST(MaterialPoint, BleSeriesMatchesAcoshAcrossTheSwitch)
{
  // acosh(1 + x)^2 switches from its series to the closed form at x = 1e-2;
  // PSTF puts theta - 1 right there: theta = (l + 1/l)/2.
  const ParameterSet p(Model("ble"));
  MaterialPointModel m{p};
  m.set_time_factor(0);
  for (double x : {0.5e-2, 0.99e-2, 1.01e-2, 2e-2})
  {
    const double l = 1 + x + std::sqrt(x * (2 + x)); // (l + 1/l)/2 = 1 + x
    const double exact = exact_response(m, LoadCase::PSTF, l).stress;
    const double paper = *paper_response(p, LoadCase::PSTF, MuscleState::passive, l);
    EXPECT_NEAR(exact, paper, 1e-12 * std::abs(paper)) << "x=" << x;
  }
}
