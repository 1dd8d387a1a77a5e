#include "fem/analysis/rigid_rotation.h"

#include <Eigen/Dense>
#include <cmath>
#include <dolfinx/common/IndexMap.h>
#include <dolfinx/fem/DofMap.h>

namespace muscle
{

std::array<double, 3> rotation_vector(const dolfinx::fem::Function<double>& u,
                                      const std::vector<std::int32_t>& cells)
{
  const auto& V = *u.function_space();
  const auto& dofmap = *V.dofmap();
  const std::int32_t owned = dofmap.index_map->size_local();
  std::vector<char> seen(owned, 0);
  for (std::int32_t c : cells)
    for (std::int32_t b : dofmap.cell_dofs(c))
      if (b < owned)
        seen[b] = 1;
  const std::vector<double> X = V.tabulate_dof_coordinates(false);
  const std::span<const double> a = u.x()->array();
  // sums: count, X, x, X x^T
  std::array<double, 16> s{};
  for (std::int32_t b = 0; b < owned; ++b)
  {
    if (!seen[b])
      continue;
    s[0] += 1;
    for (int i = 0; i < 3; ++i)
    {
      s[1 + i] += X[3 * b + i];
      s[4 + i] += X[3 * b + i] + a[3 * b + i];
      for (int j = 0; j < 3; ++j)
        s[7 + 3 * i + j] += X[3 * b + i] * (X[3 * b + j] + a[3 * b + j]);
    }
  }
  MPI_Allreduce(MPI_IN_PLACE, s.data(), s.size(), MPI_DOUBLE, MPI_SUM, V.mesh()->comm());
  Eigen::Matrix3d H;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      H(i, j) = s[7 + 3 * i + j] - s[1 + i] * s[4 + j] / s[0];
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixV() * svd.matrixU().transpose();
  if (R.determinant() < 0)
  {
    Eigen::Matrix3d V2 = svd.matrixV();
    V2.col(2) *= -1;
    R = V2 * svd.matrixU().transpose();
  }
  const Eigen::AngleAxisd aa(R);
  const double degrees = aa.angle() * 180 / M_PI;
  return {aa.axis()[0] * degrees, aa.axis()[1] * degrees, aa.axis()[2] * degrees};
}

} // namespace muscle
