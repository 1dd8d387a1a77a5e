#pragma once
// Small 3x3 helpers shared by the point-wise tests (row-major Matrix3).
#include <material/material_point.h>

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

/// Fourth-order central difference of f at 0 with step h.
template <typename F>
double central(F&& f, double h)
{
  return (-f(2 * h) + 8 * f(h) - 8 * f(-h) + f(-2 * h)) / (12 * h);
}
} // namespace muscle::testing
