// GAMG's near-null space per body: on a mesh of two separately meshed blocks
// (no shared node), the linearised stiffness at the stress-free reference has
// each block's six rigid motions in its kernel -- a fact of continuum
// mechanics, not of the code -- so every mode of rigid_body_modes(per body)
// must give K z = 0 to round-off and vanish on the other block; the global
// set has six, the per-body set twelve.
#include <fem/elements/muscle_problem.h>
#include <fem/newton/nonlinear_solver.h>
#include <fem/linear/rigid_body_modes.h>
#include <material/parameters.h>

#include <cmath>
#include <dolfinx/common/MPI.h>
#include <dolfinx/fem/CoordinateElement.h>
#include <dolfinx/fem/DofMap.h>
#include <dolfinx/mesh/Mesh.h>
#include <dolfinx/mesh/cell_types.h>
#include <gtest/gtest.h>

using namespace muscle;
using namespace dolfinx;

namespace
{
/// Two blocks of n^3 hexahedra: [0,1]^3 and [1.5,2.5]x[0,1]x[0,1.4], nodes not shared.
std::shared_ptr<mesh::Mesh> two_blocks(int n)
{
  std::vector<double> x;
  std::vector<std::int64_t> cells;
  std::vector<std::int32_t> offsets{0};
  const bool root = dolfinx::MPI::rank(MPI_COMM_WORLD) == 0;
  const std::array<std::array<double, 3>, 2> origin{{{0, 0, 0}, {1.5, 0, 0}}};
  const std::array<double, 2> height{1.0, 1.4};
  for (int b = 0; b < 2 and root; ++b)
  {
    const std::int64_t first = x.size() / 3;
    auto node = [&](int i, int j, int k) { return first + i + (n + 1) * (j + (n + 1) * k); };
    for (int k = 0; k <= n; ++k)
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i)
          x.insert(x.end(), {origin[b][0] + double(i) / n, double(j) / n,
                             height[b] * k / n});
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
        {
          // DOLFINx's hexahedron: vertices in lexicographic order, x fastest
          for (int c = 0; c < 8; ++c)
            cells.push_back(node(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)));
          offsets.push_back(cells.size());
        }
  }
  fem::CoordinateElement element(mesh::CellType::hexahedron, 1);
  return std::make_shared<mesh::Mesh>(mesh::create_mesh(
      MPI_COMM_WORLD, graph::AdjacencyList<std::int64_t>(cells, offsets), element, x,
      {x.size() / 3, 3}, mesh::GhostMode::shared_facet));
}

struct Check
{
  int modes = 0;
  double worst_kernel = 0;   ///< max |K z| / (|K| |z|)
  double worst_leak = 0;     ///< max over modes of |z on the other block| / |z|
  int modes_on_both = 0;     ///< modes with weight on both blocks
};

Check check_modes(bool per_body)
{
  auto mesh = two_blocks(3);
  ParameterSet parameters(Model("neohooke"));
  MuscleProblem problem(mesh, parameters, Discretisation{});
  NonlinearSolver solver(problem, {}); // no boundary condition: both blocks float
  Mat K = solver.assemble_tangent();
  PetscReal K_norm;
  MatNorm(K, NORM_FROBENIUS, &K_norm);

  auto V = problem.V();
  const std::int32_t n = V->dofmap()->index_map->size_local();
  const std::vector<double> coords = V->tabulate_dof_coordinates(false);
  MatNullSpace ns = rigid_body_modes(*V, nullptr, per_body);
  PetscBool has_constant;
  PetscInt count;
  const Vec* vecs;
  MatNullSpaceGetVecs(ns, &has_constant, &count, &vecs);
  Check c;
  c.modes = count;
  Vec Kz;
  MatCreateVecs(K, nullptr, &Kz);
  for (PetscInt m = 0; m < count; ++m)
  {
    MatMult(K, vecs[m], Kz);
    PetscReal kz, z;
    VecNorm(Kz, NORM_2, &kz);
    VecNorm(vecs[m], NORM_2, &z);
    c.worst_kernel = std::max(c.worst_kernel, kz / (K_norm * z));
    // the mode's weight on each block, from the node coordinates
    const PetscScalar* a;
    VecGetArrayRead(vecs[m], &a);
    double on[2] = {0, 0};
    for (std::int32_t i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k)
        on[coords[3 * i] > 1.25] += a[3 * i + k] * a[3 * i + k];
    VecRestoreArrayRead(vecs[m], &a);
    MPI_Allreduce(MPI_IN_PLACE, on, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    const double leak = std::sqrt(std::min(on[0], on[1]) / (on[0] + on[1]));
    c.worst_leak = std::max(c.worst_leak, leak);
    c.modes_on_both += leak > 1e-3;
  }
  VecDestroy(&Kz);
  MatNullSpaceDestroy(&ns);
  return c;
}
} // namespace

TEST(RigidBodyModes, TwoBlocksMeshedApartAreTwoBodies)
{
  EXPECT_EQ(mesh_bodies(*MuscleProblem(two_blocks(2), ParameterSet(Model("neohooke")),
                                       Discretisation{})
                             .V())
                .count,
            2);
}

TEST(RigidBodyModes, PerBodyModesAreInTheKernelOfEachBody)
{
  const Check c = check_modes(true);
  EXPECT_EQ(c.modes, 12);
  EXPECT_LT(c.worst_kernel, 1e-10);
  EXPECT_EQ(c.worst_leak, 0.0); // exactly zero off its body
}

TEST(RigidBodyModes, GlobalModesSpanBothBodies)
{
  const Check c = check_modes(false);
  EXPECT_EQ(c.modes, 6);
  EXPECT_LT(c.worst_kernel, 1e-10);
  EXPECT_EQ(c.modes_on_both, 6);
}
