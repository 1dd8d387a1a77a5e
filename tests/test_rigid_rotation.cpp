// The rotation of a body's best rigid fit: a displacement that is a rotation
// (plus a translation, plus a strain that rotates nothing) returns the rotation
// vector it was made with.
#include <fem/elements/muscle_problem.h>
#include <fem/analysis/rigid_rotation.h>
#include <material/parameters.h>

#include <Eigen/Geometry>
#include <cmath>
#include <dolfinx/mesh/generation.h>
#include <gtest/gtest.h>
#include <numeric>
#include <xtensor/xarray.hpp>
#include <xtensor/xbuilder.hpp>

using namespace muscle;
using namespace dolfinx;

TEST(RigidRotation, ReturnsTheRotationVectorOfARotatedBody)
{
  auto mesh = std::make_shared<mesh::Mesh>(mesh::create_box(
      MPI_COMM_WORLD, {{{0, 0, 0}, {10, 12, 30}}}, {2, 2, 4}, mesh::CellType::hexahedron,
      mesh::GhostMode::shared_facet));
  MuscleProblem problem(mesh, ParameterSet(Model("svk")), Discretisation{}, true);
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  for (double degrees : {0.5, 12.0, 75.0})
  {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(degrees * M_PI / 180, axis).toRotationMatrix();
    // a symmetric stretch along z as well: it must not count as rotation
    const Eigen::Matrix3d U = Eigen::Vector3d(1.0, 1.0, 1.1).asDiagonal();
    const Eigen::Matrix3d F = R * U;
    problem.u()->interpolate(
        [&](const xt::xtensor<double, 2>& x) -> xt::xarray<double>
        {
          xt::xarray<double> v = xt::zeros<double>({std::size_t(3), x.shape(1)});
          for (std::size_t p = 0; p < x.shape(1); ++p)
            for (int i = 0; i < 3; ++i)
            {
              v(i, p) = (i == 0 ? 2.0 : 0.0) - x(i, p);
              for (int j = 0; j < 3; ++j)
                v(i, p) += F(i, j) * x(j, p);
            }
          return v;
        });
    problem.u()->x()->scatter_fwd();
    std::vector<std::int32_t> cells(mesh->topology().index_map(3)->size_local());
    std::iota(cells.begin(), cells.end(), 0);
    const std::array<double, 3> r = rotation_vector(*problem.u(), cells);
    for (int i = 0; i < 3; ++i)
      EXPECT_NEAR(r[i], degrees * axis[i], 1e-9 * degrees) << degrees << " degrees";
  }
}
