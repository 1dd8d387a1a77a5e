#pragma once
// Small 3x3 helpers shared by the point-wise tests (row-major Matrix3).
#include "finite_differences.h"

#include <cmath>
#include <material/material_point.h>
#include <vector>

namespace muscle::testing
{
inline Matrix3 multiply(const Matrix3& A, const Matrix3& B)
{
  Matrix3 C{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        C[3 * i + j] += A[3 * i + k] * B[3 * k + j];
  return C;
}

inline double det(const Matrix3& F)
{
  return F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6])
         + F[2] * (F[3] * F[7] - F[4] * F[6]);
}

/// Within `distance` of a switch of a piecewise definition in the fibre
/// stretch (finite differences across a kink measure the kink, not the model):
/// lambda = 1 (passive fibre switch), BLE's 0.6 and 1.4 lambda_opt and
/// lambda_star, the Ehret models' lambda_min (by the parameters a law has).
inline bool near_switch(const MaterialPointModel& m, const MaterialPoint& x, double distance)
{
  const ParameterSet& p = m.parameters();
  const double l = m.fibre_stretch(x);
  std::vector<double> switches = {1.0};
  if (p.has("lambda_star")) // Blemker's fibre: active and passive pieces
    switches.insert(switches.end(),
                    {0.6 * p["lambda_opt"], 1.4 * p["lambda_opt"], p["lambda_star"]});
  if (p.has("lambda_min")) // the Ehret models' force-stretch relation
    switches.push_back(p["lambda_min"]);
  for (double s : switches)
    if (std::abs(l - s) < distance)
      return true;
  return false;
}
} // namespace muscle::testing
