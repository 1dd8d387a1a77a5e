// The Taylor-Hood element's four Newton blocks are the derivative of its
// residual [R_u; R_q] in (u, q), q = (theta, p): central differences of the
// assembled residual along a smooth direction in all of u, theta and p, for
// every paper model (WKM's stress holds omega_a, GIANT's omega_a comes from its
// quadrature-point kernel, both read the fibre stretch at F_bar).  And p-multigrid's
// prolongation: a trilinear field is a degree-1 function, so interpolating its
// degree-1 values into the degree-2 space must give its degree-2 values, and its
// Galerkin matrix must have DOLFINx's degree-1 sparsity pattern.  And the
// augmented-Lagrangian blocks against the same algebra done densely (Eigen).  And
// the vertex-star patches against their geometric definition, and their relaxation
// against PETSc's additive Schwarz on the same patches.
#include "support/finite_differences.h"

#include <fem/linear/augmented_lagrangian.h>
#include <fem/constraints/boundary.h>
#include <fem/elements/muscle_problem.h>
#include <fem/linear/p_multigrid.h>
#include <fem/linear/star_relaxation.h>
#include <fem/constraints/uniform_constraint.h>
#include <fem/linear/vertex_star.h>
#include <material/parameters.h>

#include <Eigen/Dense>
#include <basix/finite-element.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/fem/sparsitybuild.h>
#include <dolfinx/la/SparsityPattern.h>
#include <dolfinx/la/petsc.h>
#include <dolfinx/mesh/generation.h>
#include <dolfinx/mesh/utils.h>
#include <gtest/gtest.h>
#include <map>
#include <numeric>
#include <tuple>
#include <xtensor/xarray.hpp>
#include <xtensor/xbuilder.hpp>

using namespace muscle;
using namespace dolfinx;

namespace
{
struct Body
{
  std::shared_ptr<mesh::Mesh> mesh;
  std::unique_ptr<MuscleProblem> problem;
  std::size_t nu = 0, nq = 0; ///< owned + ghost unrolled dofs of u and q
};

Body make(Model model)
{
  Body b;
  b.mesh = std::make_shared<mesh::Mesh>(mesh::create_box(
      MPI_COMM_WORLD, {{{0, 0, 0}, {1, 1.2, 1.5}}}, {1, 1, 2}, mesh::CellType::hexahedron,
      mesh::GhostMode::shared_facet));
  Discretisation d;
  d.degree = 2;
  d.taylor_hood = true;
  ParameterSet parameters(model);
  parameters.set("kappa", model == Model("ble") ? 30.0 : 3.0);
  b.problem = std::make_unique<MuscleProblem>(b.mesh, parameters, d);
  b.problem->set_fibre({0.3, 0.1, 0.95});
  b.problem->set_time_factor(0.7);
  b.nu = b.problem->u()->x()->array().size();
  b.nq = b.problem->th_state()->x()->array().size();
  return b;
}

template <int N>
void interpolate(fem::Function<double>& f,
                 const std::function<std::array<double, N>(double, double, double)>& g)
{
  f.interpolate(
      [&](const xt::xtensor<double, 2>& x) -> xt::xarray<double>
      {
        xt::xarray<double> v = xt::zeros<double>({std::size_t(N), x.shape(1)});
        for (std::size_t i = 0; i < x.shape(1); ++i)
        {
          const auto y = g(x(0, i), x(1, i), x(2, i));
          for (int k = 0; k < N; ++k)
            v(k, i) = y[k];
        }
        return v;
      });
}

/// [R_u; R_q] at the current state.
std::vector<double> residual(Body& b)
{
  b.problem->update_activation();
  std::vector<double> r(b.nu + b.nq, 0.0);
  fem::assemble_vector<double>(std::span(r.data(), b.nu), *b.problem->residual());
  fem::assemble_vector<double>(std::span(r.data() + b.nu, b.nq),
                               *b.problem->th_forms().residual);
  return r;
}

/// The four blocks as one dense matrix over [u; q] (one rank: every dof).
std::vector<double> jacobian(Body& b)
{
  b.problem->update_activation();
  const std::size_t n = b.nu + b.nq;
  std::vector<double> K(n * n, 0.0);
  const auto& f = b.problem->th_forms();
  // (form, row block size, row offset, column block size, column offset)
  const std::vector<std::tuple<const fem::Form<double>*, int, std::size_t, int, std::size_t>>
      blocks = {{b.problem->jacobian().get(), 3, 0, 3, 0},
                {f.jacobian_uq.get(), 3, 0, 2, b.nu},
                {f.jacobian_qu.get(), 2, b.nu, 3, 0},
                {f.jacobian_qq.get(), 2, b.nu, 2, b.nu}};
  for (const auto& [form, rbs, roff, cbs, coff] : blocks)
  {
    auto add = [&, rbs = rbs, roff = roff, cbs = cbs, coff = coff](
                   const std::span<const std::int32_t>& rows,
                   const std::span<const std::int32_t>& cols, const std::span<const double>& v)
    {
      const std::size_t nc = cols.size() * cbs;
      for (std::size_t i = 0; i < rows.size() * rbs; ++i)
        for (std::size_t j = 0; j < nc; ++j)
          K[(roff + rows[i / rbs] * rbs + i % rbs) * n + coff + cols[j / cbs] * cbs + j % cbs]
              += v[i * nc + j];
      return 0;
    };
    fem::assemble_matrix(add, *form,
                         std::vector<std::shared_ptr<const fem::DirichletBC<double>>>{});
  }
  return K;
}

double max_abs(const std::vector<double>& v)
{
  double m = 0;
  for (double x : v)
    m = std::max(m, std::abs(x));
  return m;
}

class TaylorHoodTangent : public ::testing::TestWithParam<Model>
{
};
} // namespace

TEST_P(TaylorHoodTangent, IsTheDerivativeOfTheResidual)
{
  int ranks;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  if (ranks > 1)
    GTEST_SKIP() << "dense reference on one rank";
  const Model model = GetParam();
  Body b = make(model);
  // a state off equilibrium: bent, theta away from J, p of the penalty's order
  interpolate<3>(*b.problem->u(), [](double X, double Y, double Z) -> std::array<double, 3>
                 { return {0.05 * std::sin(2 * X + Z), 0.04 * X * Y - 0.03 * Z * Z,
                           -0.08 * Z + 0.02 * std::cos(3 * Y)}; });
  interpolate<2>(*b.problem->th_state(), [](double X, double Y, double Z) -> std::array<double, 2>
                 { return {0.97 + 0.02 * X * Z - 0.01 * Y, -3.0 + 2.0 * Y - X * Z}; });
  const std::vector<double> K = jacobian(b);
  std::vector<double> x0(b.problem->u()->x()->array().begin(),
                         b.problem->u()->x()->array().end());
  x0.insert(x0.end(), b.problem->th_state()->x()->array().begin(),
            b.problem->th_state()->x()->array().end());

  Body d = make(model);
  interpolate<3>(*d.problem->u(), [](double X, double Y, double Z) -> std::array<double, 3>
                 { return {0.3 * Y * Z, std::sin(X - Z), 0.5 * X * X - Y}; });
  interpolate<2>(*d.problem->th_state(), [](double X, double Y, double Z) -> std::array<double, 2>
                 { return {0.2 * X - 0.1 * Z * Y, 1.0 + X + 0.5 * Z}; });
  std::vector<double> delta(d.problem->u()->x()->array().begin(),
                            d.problem->u()->x()->array().end());
  delta.insert(delta.end(), d.problem->th_state()->x()->array().begin(),
               d.problem->th_state()->x()->array().end());

  auto residual_at = [&](double s)
  {
    std::span<double> u = b.problem->u()->x()->mutable_array();
    std::span<double> q = b.problem->th_state()->x()->mutable_array();
    for (std::size_t i = 0; i < b.nu; ++i)
      u[i] = x0[i] + s * delta[i];
    for (std::size_t i = 0; i < b.nq; ++i)
      q[i] = x0[b.nu + i] + s * delta[b.nu + i];
    return residual(b);
  };
  const std::vector<double> fd = muscle::testing::central_vector(residual_at, 1e-6);
  const std::size_t n = b.nu + b.nq;
  std::vector<double> diff(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
  {
    double Kd = 0;
    for (std::size_t j = 0; j < n; ++j)
      Kd += K[i * n + j] * delta[j];
    diff[i] = Kd - fd[i];
  }
  EXPECT_GT(max_abs(fd), 0);
  EXPECT_LT(max_abs(diff), 2e-6 * max_abs(fd)) << to_string(model);
  std::printf("%s: |K d - FD| / |FD| = %.2e\n", to_string(model).c_str(),
              max_abs(diff) / max_abs(fd));
}

INSTANTIATE_TEST_SUITE_P(Models, TaylorHoodTangent,
                         ::testing::Values(Model("combi"), Model("ble"), Model("wkm"),
                                           Model("giant")),
                         [](const auto& info) { return to_string(info.param); });

namespace
{
/// A prolonged vector y against the degree-2 values `fine` it must reproduce (0 at
/// the sorted local rows `zero_rows`), over every rank's owned entries: a rank may own
/// no dof of these small meshes.
void expect_reproduces(Vec y, std::span<const double> fine,
                       std::span<const std::int32_t> zero_rows = {})
{
  const PetscScalar* prolonged;
  VecGetArrayRead(y, &prolonged);
  PetscInt owned;
  VecGetLocalSize(y, &owned);
  double worst = 0, largest = 0;
  for (PetscInt i = 0; i < owned; ++i)
  {
    const bool zero = std::binary_search(zero_rows.begin(), zero_rows.end(), i);
    worst = std::max(worst, std::abs(prolonged[i] - (zero ? 0.0 : fine[i])));
    largest = std::max(largest, std::abs(fine[i]));
  }
  VecRestoreArrayRead(y, &prolonged);
  MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  EXPECT_GT(largest, 1.0);
  EXPECT_LT(worst, 1e-13 * largest);
}
} // namespace

TEST(DegreeOneCoarsening, ProlongsDegreeOneFieldsExactly)
{
  Body b = make(Model("combi"));
  auto V = b.problem->V();
  // Dirichlet rows: components x and z of the nodes on the face X = 0
  const std::vector<double> nodes = V->tabulate_dof_coordinates(false);
  std::vector<std::int32_t> dirichlet;
  for (std::size_t i = 0; i < nodes.size() / 3; ++i)
    if (std::abs(nodes[3 * i]) < 1e-12)
      dirichlet.insert(dirichlet.end(), {std::int32_t(3 * i), std::int32_t(3 * i + 2)});
  std::int64_t fixed = dirichlet.size(); // collective: a rank may own no such node
  MPI_Allreduce(MPI_IN_PLACE, &fixed, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  ASSERT_GT(fixed, 0);
  DegreeOneCoarsening coarsening(V, dirichlet);

  auto g = [](double X, double Y, double Z) -> std::array<double, 3>
  { return {1 + 2 * X - Y + 0.5 * X * Y * Z, X * Y - 3 * Z, 0.2 + Y * Z - X * Z}; };
  fem::Function<double> coarse(std::const_pointer_cast<fem::FunctionSpace>(
      coarsening.coarse_space()));
  interpolate<3>(coarse, g);
  interpolate<3>(*b.problem->u(), g);
  Vec x = la::petsc::create_vector_wrap(*coarse.x());
  Vec y;
  MatCreateVecs(coarsening.prolongation(), nullptr, &y);
  MatMult(coarsening.prolongation(), x, y);
  expect_reproduces(y, b.problem->u()->x()->array(), dirichlet);
  VecDestroy(&x);
  VecDestroy(&y);
}

TEST(DegreeOneCoarsening, LagKeepsTheGalerkinMatrixBetweenProducts)
{
  // A = c I (same object, same pattern): P^T A P = c P^T P, so its norm tells which
  // c the coarse matrix was made with
  Body b = make(Model("combi"));
  PetscOptionsSetValue(nullptr, "-fieldsplit_u_mg_coarse_lag", "2");
  DegreeOneCoarsening coarsening(b.problem->V(), {});
  PetscOptionsClearValue(nullptr, "-fieldsplit_u_mg_coarse_lag");
  PetscInt rows, columns;
  MatGetLocalSize(coarsening.prolongation(), &rows, &columns);
  Mat A;
  MatCreate(MPI_COMM_WORLD, &A);
  MatSetSizes(A, rows, rows, PETSC_DETERMINE, PETSC_DETERMINE);
  MatSetBlockSize(A, 3);
  MatSetType(A, MATAIJ);
  MatSeqAIJSetPreallocation(A, 1, nullptr);
  MatMPIAIJSetPreallocation(A, 1, nullptr, 0, nullptr);
  PetscInt begin, end;
  MatGetOwnershipRange(A, &begin, &end);
  for (PetscInt i = begin; i < end; ++i)
    MatSetValue(A, i, i, 1.0, INSERT_VALUES);
  MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
  auto norm_of_coarse = [&]
  {
    PetscReal norm;
    MatNorm(coarsening.coarse_matrix(A), NORM_FROBENIUS, &norm);
    return norm;
  };
  const PetscReal first = norm_of_coarse();
  ASSERT_GT(first, 0.0);
  MatScale(A, 2.0);
  EXPECT_NEAR(norm_of_coarse(), first, 1e-12 * first) << "the lagged call";
  EXPECT_NEAR(norm_of_coarse(), 2 * first, 1e-12 * first) << "the second product";
  MatScale(A, 2.0);
  coarsening.refresh_at_next_call(); // a new Newton solve
  EXPECT_NEAR(norm_of_coarse(), 4 * first, 1e-12 * first) << "after a refresh";
  MatDestroy(&A);
}

TEST(DegreeOneCoarsening, GalerkinMatrixCouplesVerticesOfACellOnly)
{
  // A: every pair of degree-2 dofs of a cell coupled (ones, so nothing cancels).
  // P^T A P must couple two vertices exactly when they share a cell: the degree-1
  // sparsity pattern, built here by DOLFINx from the degree-1 dofmap.  P's exact
  // zeros kept (the nodes on a vertex star's outer faces) reach two cells away.
  auto mesh = std::make_shared<mesh::Mesh>(
      mesh::create_box(MPI_COMM_WORLD, {{{0, 0, 0}, {1, 1, 1}}}, {3, 3, 4},
                       mesh::CellType::hexahedron, mesh::GhostMode::shared_facet));
  const basix::FiniteElement e2 = basix::create_element(
      basix::element::family::P, basix::cell::type::hexahedron, 2,
      basix::element::lagrange_variant::gll_warped, false);
  auto V = std::make_shared<fem::FunctionSpace>(fem::create_functionspace(mesh, e2, 3));
  DegreeOneCoarsening coarsening(V, {});

  const int tdim = mesh->topology().dim();
  std::vector<std::int32_t> cells(mesh->topology().index_map(tdim)->size_local());
  std::iota(cells.begin(), cells.end(), 0);
  auto pattern_of = [&](const fem::DofMap& dofmap)
  {
    la::SparsityPattern pattern(MPI_COMM_WORLD, {dofmap.index_map, dofmap.index_map}, {3, 3});
    fem::sparsitybuild::cells(pattern, cells, {dofmap, dofmap});
    pattern.assemble();
    return pattern;
  };
  Mat A = la::petsc::create_matrix(MPI_COMM_WORLD, pattern_of(*V->dofmap()));
  const std::vector<double> ones(81 * 81, 1.0);
  auto add = la::petsc::Matrix::set_block_fn(A, ADD_VALUES);
  for (std::int32_t c : cells)
  {
    auto dofs = V->dofmap()->cell_dofs(c);
    add(dofs, dofs, ones);
  }
  MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);

  MatInfo info;
  MatGetInfo(coarsening.coarse_matrix(A), MAT_GLOBAL_SUM, &info);
  const fem::DofMap& dofmap1 = *coarsening.coarse_space()->dofmap();
  const la::SparsityPattern pattern1 = pattern_of(dofmap1);
  std::int64_t expected = 0; // 3 x 3 entries per pair of owned and any vertex
  for (std::int32_t row = 0; row < dofmap1.index_map->size_local(); ++row)
    expected += 9 * (pattern1.nnz_diag(row) + pattern1.nnz_off_diag(row));
  MPI_Allreduce(MPI_IN_PLACE, &expected, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_EQ(std::int64_t(info.nz_used), expected);
  MatDestroy(&A);
}

TEST(DegreeOneCoarsening, RestrictedOntoAUniformAxialConstraint)
{
  // The free muscle's constraint (the top face's z displacements one unknown U):
  // R T = I; a degree-1 field whose z component is constant on the top face is a
  // coarse function of the constrained space, so T (R P) must reproduce its
  // degree-2 values exactly, U included; and each free dof's reduced number is
  // the column that T copies it from.
  Body b = make(Model("combi"));
  auto V = b.problem->V();
  b.mesh->topology_mutable().create_connectivity(2, 3);
  const std::vector<std::int32_t> top = mesh::locate_entities_boundary(
      *b.mesh, 2, [](const xt::xtensor<double, 2>& x) -> xt::xtensor<bool, 1>
      {
        xt::xtensor<bool, 1> marked = xt::zeros<bool>({x.shape(1)});
        for (std::size_t i = 0; i < x.shape(1); ++i)
          marked(i) = std::abs(x(2, i) - 1.5) < 1e-12;
        return marked;
      });
  UniformDisplacementConstraint constraint(*V, component_dofs(*V, top, 2));
  Mat T = constraint.T();
  Mat R = constraint.restriction();
  Mat RT;
  MatMatMult(R, T, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &RT);
  MatShift(RT, -1.0);
  PetscReal off;
  MatNorm(RT, NORM_INFINITY, &off);
  EXPECT_LT(off, 1e-14) << "R T - I";
  MatDestroy(&RT);

  DegreeOneCoarsening coarsening(V, {});
  coarsening.restrict_rows(R);
  MatDestroy(&R);
  auto g = [](double X, double Y, double Z) -> std::array<double, 3>
  { return {1 + 2 * X - Y + 0.5 * X * Y * Z, X * Y - 3 * Z, 0.2 + X * Y * (Z - 1.5)}; };
  fem::Function<double> coarse(std::const_pointer_cast<fem::FunctionSpace>(
      coarsening.coarse_space()));
  interpolate<3>(coarse, g);
  interpolate<3>(*b.problem->u(), g);
  Vec x = la::petsc::create_vector_wrap(*coarse.x());
  Vec reduced = constraint.create_reduced_vector(), full;
  MatCreateVecs(T, nullptr, &full);
  MatMult(coarsening.prolongation(), x, reduced);
  MatMult(T, reduced, full);
  expect_reproduces(full, b.problem->u()->x()->array());
  PetscInt owned;
  VecGetLocalSize(full, &owned);

  // reduced numbers: T copies a free dof from its number's column
  VecSetRandom(reduced, nullptr);
  MatMult(T, reduced, full);
  const PetscScalar *xr, *xf;
  VecGetArrayRead(reduced, &xr);
  VecGetArrayRead(full, &xf);
  PetscInt start, end;
  VecGetOwnershipRange(reduced, &start, &end);
  const std::vector<std::int64_t> numbers = constraint.reduced_numbers();
  EXPECT_EQ(numbers.size(), std::size_t(owned));
  // counted, not asserted inside the loop: an early return on one rank would leave the
  // others waiting in the reductions below
  std::int64_t free = 0, tied = 0, wrong = 0;
  for (PetscInt i = 0; i < std::min(owned, PetscInt(numbers.size())); ++i)
  {
    if (numbers[i] < 0)
    {
      ++tied;
      continue;
    }
    ++free;
    if (numbers[i] < start or numbers[i] >= end or xf[i] != xr[numbers[i] - start])
      ++wrong;
  }
  VecRestoreArrayRead(reduced, &xr);
  VecRestoreArrayRead(full, &xf);
  for (Vec* v : {&x, &reduced, &full})
    VecDestroy(v);
  EXPECT_EQ(wrong, 0) << "free dofs whose number is not the column T copies them from";

  // the stars renumbered so: each is the full star's renumbered dofs, the tied left out
  la::Vector<double> local(V->dofmap()->index_map, 3);
  std::copy(numbers.begin(), numbers.end(), local.mutable_array().begin());
  local.scatter_fwd();
  const std::vector<std::int64_t> renumber(local.array().begin(), local.array().end());
  std::vector<std::int64_t> global_of(renumber.size());
  {
    std::vector<std::int32_t> nodes(renumber.size() / 3);
    std::iota(nodes.begin(), nodes.end(), 0);
    std::vector<std::int64_t> global_nodes(nodes.size());
    V->dofmap()->index_map->local_to_global(nodes, global_nodes);
    for (std::size_t i = 0; i < renumber.size(); ++i)
      global_of[i] = 3 * global_nodes[i / 3] + i % 3;
  }
  std::map<std::int64_t, std::int64_t> number_of;
  for (std::size_t i = 0; i < renumber.size(); ++i)
    number_of[global_of[i]] = renumber[i];
  std::vector<IS> stars = vertex_star_patches(*V), renumbered = vertex_star_patches(*V, renumber);
  EXPECT_EQ(stars.size(), renumbered.size());
  std::int64_t unlike = 0;
  for (std::size_t p = 0; p < std::min(stars.size(), renumbered.size()); ++p)
  {
    auto entries = [](IS patch)
    {
      PetscInt n;
      const PetscInt* rows;
      ISGetLocalSize(patch, &n);
      ISGetIndices(patch, &rows);
      std::vector<std::int64_t> out(rows, rows + n);
      ISRestoreIndices(patch, &rows);
      return out;
    };
    std::vector<std::int64_t> expected;
    for (std::int64_t dof : entries(stars[p]))
      if (number_of.at(dof) >= 0)
        expected.push_back(number_of.at(dof));
    std::sort(expected.begin(), expected.end());
    std::vector<std::int64_t> got = entries(renumbered[p]);
    std::sort(got.begin(), got.end());
    unlike += expected != got;
  }
  for (std::vector<IS>* patches : {&stars, &renumbered})
    for (IS& patch : *patches)
      ISDestroy(&patch);
  EXPECT_EQ(unlike, 0) << "renumbered stars";
  EXPECT_EQ(free + tied, owned);
  MPI_Allreduce(MPI_IN_PLACE, &tied, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_EQ(tied, 3 * 3); // the top face's degree-2 nodes (one cell)
}

TEST(VertexStar, PatchesAreTheStarsOfTheVertices)
{
  // On a grid of cubes of side h, the star of vertex v (its own, edge, face and cell
  // nodes) holds exactly the degree-2 nodes x with |x - v|_inf < h: 27 nodes inside,
  // 8 at a corner of the box.  Counted here from coordinates, not from entities.
  const double h = 0.5;
  auto mesh = std::make_shared<mesh::Mesh>(mesh::create_box(
      MPI_COMM_WORLD, {{{0, 0, 0}, {2 * h, 3 * h, 2 * h}}}, {2, 3, 2},
      mesh::CellType::hexahedron, mesh::GhostMode::shared_facet)); // as gmsh_mesh.cpp
  Discretisation d;
  d.degree = 2;
  d.taylor_hood = true;
  MuscleProblem problem(mesh, ParameterSet(Model("combi")), d);
  const fem::FunctionSpace& V = *problem.V();
  const std::vector<double> x = V.tabulate_dof_coordinates(false);
  const std::vector<std::int64_t> global = V.dofmap()->index_map->global_indices();
  auto node_of = [&global](std::int64_t dof)
  {
    auto it = std::find(global.begin(), global.end(), dof / 3);
    EXPECT_NE(it, global.end()) << "dof " << dof << " is not seen on this rank";
    return std::size_t(it - global.begin());
  };
  auto is_vertex = [&x, h](std::size_t node)
  {
    for (int i = 0; i < 3; ++i)
      if (std::abs(std::round(x[3 * node + i] / h) * h - x[3 * node + i]) > 1e-12)
        return false;
    return true;
  };

  int comm_size;
  MPI_Comm_size(MPI_COMM_WORLD, &comm_size);
  std::vector<IS> patches = vertex_star_patches(V);
  std::vector<std::size_t> sizes;
  std::vector<std::int64_t> covered;
  // first one star per owned vertex, then at most one block of the rest
  const std::size_t owned_vertices = mesh->topology().index_map(0)->size_local();
  ASSERT_GE(patches.size(), owned_vertices);
  ASSERT_LE(patches.size(), owned_vertices + 1);
  if (comm_size == 1)
    ASSERT_EQ(patches.size(), owned_vertices);
  for (std::size_t p = 0; p < patches.size(); ++p)
  {
    IS patch = patches[p];
    PetscInt n;
    const PetscInt* dofs;
    ISGetLocalSize(patch, &n);
    ISGetIndices(patch, &dofs);
    ASSERT_EQ(n % 3, 0);
    std::vector<std::size_t> nodes;
    for (PetscInt i = 0; i < n; i += 3)
    {
      EXPECT_EQ(dofs[i + 1], dofs[i] + 1);
      EXPECT_EQ(dofs[i + 2], dofs[i] + 2);
      nodes.push_back(node_of(dofs[i]));
      covered.push_back(dofs[i] / 3);
    }
    ISRestoreIndices(patch, &dofs);
    std::vector<std::size_t> vertices;
    std::copy_if(nodes.begin(), nodes.end(), std::back_inserter(vertices), is_vertex);
    // on several ranks the last block may hold the owned nodes of no owned star
    if (p >= owned_vertices) // the owned nodes of no owned star
      continue;
    ASSERT_EQ(vertices.size(), 1u) << "a star holds one mesh vertex, its centre";
    const double* v = &x[3 * vertices[0]];
    std::size_t in_star = 0; // the nodes of the whole box within the star
    for (std::size_t node = 0; node < x.size() / 3; ++node)
    {
      double distance = 0;
      for (int i = 0; i < 3; ++i)
        distance = std::max(distance, std::abs(x[3 * node + i] - v[i]));
      in_star += distance < h - 1e-12;
    }
    for (std::size_t node : nodes)
      for (int i = 0; i < 3; ++i)
        EXPECT_LT(std::abs(x[3 * node + i] - v[i]), h - 1e-12);
    if (comm_size == 1) // a partition boundary cuts stars
      EXPECT_EQ(nodes.size(), in_star);
    sizes.push_back(nodes.size());
  }
  for (IS& patch : patches)
    ISDestroy(&patch);
  if (comm_size == 1)
  {
    EXPECT_EQ(sizes.size(), 3u * 4u * 3u); // the vertices
    EXPECT_EQ(std::count(sizes.begin(), sizes.end(), 27u), 2); // the inner ones
    EXPECT_EQ(std::count(sizes.begin(), sizes.end(), 8u), 8);  // the box's corners
  }
  // every owned node in some patch
  std::sort(covered.begin(), covered.end());
  covered.erase(std::unique(covered.begin(), covered.end()), covered.end());
  const std::int32_t owned = V.dofmap()->index_map->size_local();
  for (std::int32_t node = 0; node < owned; ++node)
    EXPECT_TRUE(std::binary_search(covered.begin(), covered.end(), global[node]))
        << "node " << global[node] << " in no patch";
}

namespace
{
/// The displacement block of a Taylor-Hood COMBI box (2 x 3 x 2 cells) in a smooth
/// deformation, assembled over all ranks, and its vertex-star patches
struct StarCase
{
  Mat A = nullptr;
  std::vector<IS> patches;
  StarCase()
  {
    auto mesh = std::make_shared<mesh::Mesh>(mesh::create_box(
        MPI_COMM_WORLD, {{{0, 0, 0}, {1, 1.5, 1}}}, {2, 3, 2}, mesh::CellType::hexahedron,
        mesh::GhostMode::shared_facet));
    Discretisation d;
    d.degree = 2;
    d.taylor_hood = true;
    MuscleProblem problem(mesh, ParameterSet(Model("combi")), d);
    problem.set_fibre({0.3, 0.1, 0.95});
    problem.set_time_factor(0.7);
    interpolate<3>(*problem.u(), [](double x, double y, double z) -> std::array<double, 3>
                   { return {0.05 * y * z, -0.04 * x * x, 0.06 * x * y}; });
    problem.update_activation();
    A = fem::petsc::create_matrix(*problem.jacobian());
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(A, ADD_VALUES), *problem.jacobian(),
                         std::vector<std::shared_ptr<const fem::DirichletBC<double>>>{});
    MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
    patches = vertex_star_patches(*problem.V());
  }
  ~StarCase()
  {
    MatDestroy(&A);
    for (IS& patch : patches)
      ISDestroy(&patch);
  }
  PC stars() const
  {
    PC pc;
    PCCreate(MPI_COMM_WORLD, &pc);
    register_star_relaxation();
    PCSetType(pc, PCSTARS);
    set_star_patches(pc, patches);
    PCSetOperators(pc, A, A);
    return pc;
  }
};
} // namespace

TEST(StarRelaxation, AppliesWhatPCASMAppliesOnTheSamePatches)
{
  // PETSc's additive Schwarz on the same subdomains, without overlap weights
  // (BASIC), each block solved by LU, is the same operator sum_i R_i^T A_i^-1 R_i
  // (in double precision with -pc_stars_double, to round-off; in the default
  // single precision to the rounding of the inverses' entries)
  StarCase c;
  PC stars = c.stars(), stars_single = c.stars();
  PCSetOptionsPrefix(stars, "double_");
  PetscOptionsSetValue(nullptr, "-double_pc_stars_double", "1");
  PC asm_pc;
  PCCreate(MPI_COMM_WORLD, &asm_pc);
  PCSetOptionsPrefix(asm_pc, "reference_");
  PCSetType(asm_pc, PCASM);
  PCASMSetLocalSubdomains(asm_pc, c.patches.size(), c.patches.data(), nullptr);
  PCASMSetType(asm_pc, PC_ASM_BASIC);
  PetscOptionsSetValue(nullptr, "-reference_sub_ksp_type", "preonly");
  PetscOptionsSetValue(nullptr, "-reference_sub_pc_type", "lu");
  PCSetFromOptions(asm_pc);
  PCSetOperators(asm_pc, c.A, c.A);
  PCSetUp(stars);
  PCSetUp(stars_single);
  PCSetUp(asm_pc);
  PetscOptionsClearValue(nullptr, "-double_pc_stars_double");
  PCFailedReason reason;
  PCGetFailedReason(stars, &reason);
  EXPECT_EQ(reason, PC_NOERROR);

  Vec x, y, y_asm;
  MatCreateVecs(c.A, &x, &y);
  VecDuplicate(y, &y_asm);
  PetscRandom random;
  PetscRandomCreate(MPI_COMM_WORLD, &random);
  PetscRandomSetSeed(random, 7);
  PetscRandomSeed(random);
  VecSetRandom(x, random);
  PCApply(asm_pc, x, y_asm);
  PetscReal norm;
  VecNorm(y_asm, NORM_INFINITY, &norm);
  EXPECT_GT(norm, 0.0);
  PCGetFailedReason(stars_single, &reason);
  EXPECT_EQ(reason, PC_NOERROR);
  // single: within its rounding (6.5e-8 of the norm measured), but not at round-off
  // of double, or -pc_stars_double would have gone to both
  for (auto [pc, tolerance, floor] :
       {std::tuple{stars, 1e-10, 0.0}, std::tuple{stars_single, 1e-6, 1e-12}})
  {
    PCApply(pc, x, y);
    VecAYPX(y, -1.0, y_asm);
    PetscReal difference;
    VecNorm(y, NORM_INFINITY, &difference);
    EXPECT_LT(difference, tolerance * norm) << (pc == stars ? "double" : "single");
    EXPECT_GE(difference, floor * norm) << (pc == stars ? "double" : "single");
  }

  PetscRandomDestroy(&random);
  VecDestroy(&x);
  VecDestroy(&y);
  VecDestroy(&y_asm);
  PCDestroy(&stars);
  PCDestroy(&stars_single);
  PCDestroy(&asm_pc);
}

TEST(StarRelaxation, SingularPatchIsAZeroPivotFailure)
{
  // a failure the Newton solve can answer with a shorter step, not an error; a pivot
  // at round-off is one too (not an inverse of 1e20), on every rank; and it is gone
  // when the operator is sound again
  StarCase c;
  Mat sound;
  MatDuplicate(c.A, MAT_COPY_VALUES, &sound);
  PetscInt start;
  MatGetOwnershipRange(c.A, &start, nullptr);
  int rank;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  const PetscInt row = start;
  PC stars = c.stars();
  for (double diagonal : {0.0, 1e-20})
  {
    MatCopy(sound, c.A, SAME_NONZERO_PATTERN);
    MatZeroRowsColumns(c.A, rank == 0 ? 1 : 0, &row, diagonal, nullptr, nullptr);
    PCSetUp(stars);
    PCFailedReason reason;
    PCGetFailedReason(stars, &reason);
    EXPECT_EQ(reason, PC_FACTOR_NUMERIC_ZEROPIVOT) << "diagonal " << diagonal;
  }
  MatCopy(sound, c.A, SAME_NONZERO_PATTERN);
  PCSetUp(stars);
  PCFailedReason reason;
  PCGetFailedReason(stars, &reason);
  EXPECT_EQ(reason, PC_NOERROR);
  PCDestroy(&stars);
  MatDestroy(&sound);
}

namespace
{
Mat sparse_copy(const Eigen::MatrixXd& D)
{
  Mat M;
  MatCreateSeqAIJ(PETSC_COMM_SELF, D.rows(), D.cols(), D.cols(), nullptr, &M);
  for (int i = 0; i < D.rows(); ++i)
    for (int j = 0; j < D.cols(); ++j)
      if (D(i, j) != 0)
        MatSetValue(M, i, j, D(i, j), INSERT_VALUES);
  MatAssemblyBegin(M, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(M, MAT_FINAL_ASSEMBLY);
  return M;
}

Eigen::MatrixXd dense_copy(Mat M)
{
  PetscInt m, n;
  MatGetSize(M, &m, &n);
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(m, n);
  for (PetscInt i = 0; i < m; ++i)
  {
    PetscInt k;
    const PetscInt* cols;
    const PetscScalar* values;
    MatGetRow(M, i, &k, &cols, &values);
    for (PetscInt j = 0; j < k; ++j)
      D(i, cols[j]) = values[j];
    MatRestoreRow(M, i, &k, &cols, &values);
  }
  return D;
}
/// D as a displacement block: block size 3, the nodes numbered alike locally and
/// globally (begin() inserts through the local-to-global map)
Mat displacement_copy(const Eigen::MatrixXd& D)
{
  Mat M = sparse_copy(D);
  MatSetBlockSize(M, 3);
  std::vector<PetscInt> identity(D.rows() / 3);
  std::iota(identity.begin(), identity.end(), 0);
  ISLocalToGlobalMapping l2g;
  ISLocalToGlobalMappingCreate(PETSC_COMM_SELF, 3, identity.size(), identity.data(),
                               PETSC_COPY_VALUES, &l2g);
  MatSetLocalToGlobalMapping(M, l2g, l2g);
  ISLocalToGlobalMappingDestroy(&l2g);
  return M;
}

/// An operator's matrix, column by column from its products with unit vectors
Eigen::MatrixXd dense_operator(Mat M)
{
  PetscInt m, n;
  MatGetSize(M, &m, &n);
  Vec e, column;
  MatCreateVecs(M, &e, &column);
  Eigen::MatrixXd D(m, n);
  for (PetscInt j = 0; j < n; ++j)
  {
    VecZeroEntries(e);
    VecSetValue(e, j, 1.0, INSERT_VALUES);
    VecAssemblyBegin(e);
    VecAssemblyEnd(e);
    MatMult(M, e, column);
    const PetscScalar* a;
    VecGetArrayRead(column, &a);
    for (PetscInt i = 0; i < m; ++i)
      D(i, j) = a[i];
    VecRestoreArrayRead(column, &a);
  }
  VecDestroy(&e);
  VecDestroy(&column);
  return D;
}
} // namespace

TEST(AugmentedLagrangian, MatchesDenseAlgebra)
{
  // two cells on a line of three nodes, each node one displacement block (3
  // dofs) and one (theta, p) pair; the cells share the middle node
  const int nodes = 3;
  const std::array<std::array<std::int32_t, 2>, 2> cells = {{{0, 1}, {1, 2}}};
  std::srand(7);
  Eigen::MatrixXd A = Eigen::MatrixXd::Random(3 * nodes, 3 * nodes);
  A = A + A.transpose();
  // a mesh's pattern: nodes 0 and 2 share no cell
  A.block<3, 3>(0, 6).setZero();
  A.block<3, 3>(6, 0).setZero();
  Eigen::MatrixXd A_qu = Eigen::MatrixXd::Zero(2 * nodes, 3 * nodes);
  Eigen::MatrixXd A_qq = Eigen::MatrixXd::Zero(2 * nodes, 2 * nodes);
  std::array<Eigen::MatrixXd, 2> qu_e, qq_e;
  for (int c = 0; c < 2; ++c)
  {
    Eigen::MatrixXd M(2, 2); // a cell mass matrix: symmetric, positive rows
    M << 2 + c, 1, 1, 3 - c;
    qq_e[c] = Eigen::MatrixXd::Zero(4, 4);
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j)
      {
        qq_e[c](2 * i, 2 * j) = 1000 * M(i, j); // kappa M on (theta, theta)
        qq_e[c](2 * i, 2 * j + 1) = qq_e[c](2 * i + 1, 2 * j) = -M(i, j);
      }
    qu_e[c] = Eigen::MatrixXd::Random(4, 6);
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j)
      {
        A_qq.block<2, 2>(2 * cells[c][i], 2 * cells[c][j]) += qq_e[c].block<2, 2>(2 * i, 2 * j);
        A_qu.block<2, 3>(2 * cells[c][i], 3 * cells[c][j]) += qu_e[c].block<2, 3>(2 * i, 3 * j);
      }
  }
  const double gamma = 2.5;
  // expected: gamma sum_c B_c^T W_c^-1 B_c in the global numbering, W_c the
  // cell's lumped mass; the right-hand side's W the global lumped mass
  Eigen::MatrixXd cell_sum = Eigen::MatrixXd::Zero(3 * nodes, 3 * nodes);
  for (int c = 0; c < 2; ++c)
  {
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(2, 3 * nodes);
    Eigen::VectorXd w(2);
    for (int i = 0; i < 2; ++i)
    {
      w(i) = -(qq_e[c](2 * i, 1) + qq_e[c](2 * i, 3));
      for (int j = 0; j < 2; ++j)
        B.block<1, 3>(i, 3 * cells[c][j]) = qu_e[c].block<1, 3>(2 * i + 1, 3 * j);
    }
    cell_sum += gamma * B.transpose() * w.cwiseInverse().asDiagonal() * B;
  }

  // A_gamma in A's own storage, GMRES's A an operator: on the first call, on the
  // update in place, and after a new nonzero in A (contact coupling nodes 0 and 2)
  AugmentedLagrangian al(gamma);
  Mat pA = displacement_copy(A), pA_qu = sparse_copy(A_qu), pA_qq = sparse_copy(A_qq);
  // scale: the coupling's element matrices times scale (each call's B_b must be refilled)
  auto assemble_cells = [&](AugmentedLagrangian& al, Mat A_now, std::array<int, 2> order,
                            double scale = 1.0)
  {
    al.begin(A_now);
    for (int c = 0; c < 2; ++c)
    {
      const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> e = qq_e[c];
      al.add_cell_mass(cells[c], std::span(e.data(), e.size()));
    }
    for (int c : order)
    {
      const Eigen::Matrix<double, 4, 6, Eigen::RowMajor> e = scale * qu_e[c];
      al.add_cell_coupling(cells[c], cells[c], std::span(e.data(), e.size()));
    }
    al.end(pA_qq);
  };
  Eigen::MatrixXd expected_A = A;
  for (int call = 0; call < 3; ++call)
  {
    if (call == 1)
      expected_A *= -3.0;
    if (call == 2)
    {
      MatSetOption(pA, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
      expected_A(0, 7) = expected_A(7, 0) = 0.5;
    }
    // A assembled anew, as each Newton iteration does
    MatZeroEntries(pA);
    for (int i = 0; i < 3 * nodes; ++i)
      for (int j = 0; j < 3 * nodes; ++j)
        if (expected_A(i, j) != 0)
          MatSetValue(pA, i, j, expected_A(i, j), INSERT_VALUES);
    MatAssemblyBegin(pA, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(pA, MAT_FINAL_ASSEMBLY);
    const double scale = std::array<double, 3>{1.0, 2.0, 0.5}[call];
    assemble_cells(al, pA, {0, 1}, scale);
    EXPECT_EQ(al.matrix(), pA);
    const Eigen::MatrixXd expected = expected_A + scale * scale * cell_sum;
    const Eigen::MatrixXd got = dense_copy(al.matrix());
    EXPECT_LT((got - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff())
        << "call " << call;
    const Eigen::MatrixXd block = dense_operator(al.jacobian_block(pA, nullptr));
    EXPECT_LT((block - expected_A).cwiseAbs().maxCoeff(),
              1e-12 * expected.cwiseAbs().maxCoeff())
        << "call " << call;
  }

  // under a constraint u = T x: T^T A T from T^T A_gamma T less the cells' terms
  {
    Eigen::MatrixXd T_dense = Eigen::MatrixXd::Zero(3 * nodes, 4);
    for (int i = 0; i < 3 * nodes; ++i)
      T_dense(i, i % 4) = 1.0 + 0.1 * i; // every full dof on one reduced unknown
    Mat T = sparse_copy(T_dense);
    Mat A_full = displacement_copy(A);
    AugmentedLagrangian constrained(gamma);
    assemble_cells(constrained, A_full, {0, 1});
    Mat reduced;
    MatPtAP(A_full, T, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &reduced);
    const Eigen::MatrixXd block = dense_operator(constrained.jacobian_block(reduced, T));
    const Eigen::MatrixXd expected = T_dense.transpose() * A * T_dense;
    EXPECT_LT((block - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
    for (Mat* m : {&T, &A_full, &reduced})
      MatDestroy(m);
  }

  // cells of A_qu's assembly that do not follow A_qq's are reported
  EXPECT_THROW(assemble_cells(al, pA, {1, 0}), std::logic_error);

  // rhs_u += gamma B^T W^-1 (r_q - A_qq z_q)|_p with the assembled B and W
  Eigen::MatrixXd B(nodes, 3 * nodes);
  Eigen::VectorXd w(nodes);
  for (int i = 0; i < nodes; ++i)
  {
    B.row(i) = A_qu.row(2 * i + 1);
    w(i) = 0;
    for (int j = 0; j < nodes; ++j)
      w(i) -= A_qq(2 * i, 2 * j + 1);
  }
  const Eigen::VectorXd r_q = Eigen::VectorXd::Random(2 * nodes);
  const Eigen::VectorXd z_q = Eigen::VectorXd::Random(2 * nodes);
  const Eigen::VectorXd rhs = Eigen::VectorXd::Random(3 * nodes);
  const Eigen::VectorXd residual = r_q - A_qq * z_q;
  Eigen::VectorXd p_part(nodes);
  for (int i = 0; i < nodes; ++i)
    p_part(i) = residual(2 * i + 1) / w(i);
  const Eigen::VectorXd expected = rhs + gamma * B.transpose() * p_part;
  Vec v_rhs, v_r, v_z;
  VecCreateSeq(PETSC_COMM_SELF, 3 * nodes, &v_rhs);
  VecCreateSeq(PETSC_COMM_SELF, 2 * nodes, &v_r);
  VecCreateSeq(PETSC_COMM_SELF, 2 * nodes, &v_z);
  for (int i = 0; i < 3 * nodes; ++i)
    VecSetValue(v_rhs, i, rhs(i), INSERT_VALUES);
  for (int i = 0; i < 2 * nodes; ++i)
  {
    VecSetValue(v_r, i, r_q(i), INSERT_VALUES);
    VecSetValue(v_z, i, z_q(i), INSERT_VALUES);
  }
  for (Vec v : {v_rhs, v_r, v_z})
  {
    VecAssemblyBegin(v);
    VecAssemblyEnd(v);
  }
  EXPECT_EQ(al.add_constraint_rows(v_rhs, v_r, v_z, pA_qu, pA_qq), 0);
  const PetscScalar* got;
  VecGetArrayRead(v_rhs, &got);
  for (int i = 0; i < 3 * nodes; ++i)
    EXPECT_NEAR(got[i], expected(i), 1e-12 * expected.cwiseAbs().maxCoeff()) << i;
  VecRestoreArrayRead(v_rhs, &got);
  for (Vec* v : {&v_rhs, &v_r, &v_z})
    VecDestroy(v);
  for (Mat* m : {&pA, &pA_qu, &pA_qq})
    MatDestroy(m);
}
