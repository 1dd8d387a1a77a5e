// The F-bar hexahedron eliminates J0 = det F(centre) from a mixed (u, J0)
// kernel cell by cell.  References independent of that elimination:
//  * central differences of the assembled residual (the tangent, every model,
//    including WKM's non-symmetric one and the kernels' omega_a(lambda));
//  * plain Q1 for a homogeneous deformation, where J0 = J at every point and
//    F_bar = F, so both elements must give the same residual;
//  * and it must differ from plain Q1 as soon as J varies within a cell.
#include "support/finite_differences.h"

#include <loadcases/load_case.h>
#include <fem/elements/muscle_problem.h>
#include <material/parameters.h>

#include <cmath>
#include <cstdio>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/mesh/generation.h>
#include <functional>
#include <gtest/gtest.h>
#include <xtensor/xarray.hpp>
#include <xtensor/xbuilder.hpp>

using namespace muscle;
using namespace dolfinx;

namespace
{
using Field = std::function<std::array<double, 3>(double, double, double)>;

struct Body
{
  std::shared_ptr<mesh::Mesh> mesh;
  std::unique_ptr<MuscleProblem> problem;
  std::size_t size = 0; ///< owned + ghost unrolled dofs
};

Body make(Model model, bool fbar, bool passive = false)
{
  Body b;
  b.mesh = std::make_shared<mesh::Mesh>(mesh::create_box(
      MPI_COMM_WORLD, {{{0, 0, 0}, {1, 1.2, 1.5}}}, {2, 2, 3}, mesh::CellType::hexahedron,
      mesh::GhostMode::shared_facet));
  Discretisation d;
  d.fbar = fbar;
  // a soft penalty, so that the active and the Ehret terms weigh as much as it
  ParameterSet parameters(model);
  parameters.set("kappa", model == Model("ble") ? 30.0 : 3.0);
  b.problem = std::make_unique<MuscleProblem>(b.mesh, parameters, d, passive);
  b.problem->set_fibre({0.3, 0.1, 0.95});
  b.problem->set_time_factor(0.7);
  const auto map = b.problem->V()->dofmap()->index_map;
  b.size = (map->size_local() + map->num_ghosts()) * 3;
  return b;
}

void set_displacement(Body& b, const Field& f)
{
  b.problem->u()->interpolate(
      [&](const xt::xtensor<double, 2>& x) -> xt::xarray<double>
      {
        xt::xarray<double> v = xt::zeros<double>({std::size_t(3), x.shape(1)});
        for (std::size_t i = 0; i < x.shape(1); ++i)
        {
          const auto u = f(x(0, i), x(1, i), x(2, i));
          for (int k = 0; k < 3; ++k)
            v(k, i) = u[k];
        }
        return v;
      });
  b.problem->u()->x()->scatter_fwd();
  b.problem->update_activation();
}

// smooth, non-homogeneous, about 5 % strain and 1-2 % volume change
std::array<double, 3> bent(double X, double Y, double Z)
{
  return {0.05 * std::sin(2 * X + Z), 0.04 * X * Y - 0.03 * Z * Z,
          -0.08 * Z + 0.02 * std::cos(3 * Y)};
}

std::vector<double> residual(const Body& b)
{
  std::vector<double> r(b.size, 0.0);
  fem::assemble_vector<double>(r, *b.problem->residual());
  return r;
}

/// K as a dense matrix over owned and ghost dofs (one rank: all of them).
std::vector<double> tangent(const Body& b)
{
  const std::size_t n = b.size;
  std::vector<double> K(n * n, 0.0);
  auto add = [&](const std::span<const std::int32_t>& rows,
                 const std::span<const std::int32_t>& cols, const std::span<const double>& v)
  {
    for (std::size_t i = 0; i < rows.size(); ++i)
      for (std::size_t j = 0; j < cols.size(); ++j)
        K[rows[i] * n + cols[j]] += v[i * cols.size() + j];
    return 0;
  };
  // blocked dofs (block size 3) -> unrolled
  auto add_blocked = [&](const std::span<const std::int32_t>& rows,
                         const std::span<const std::int32_t>& cols,
                         const std::span<const double>& v)
  {
    std::vector<std::int32_t> r, c;
    for (auto i : rows)
      for (int k = 0; k < 3; ++k)
        r.push_back(3 * i + k);
    for (auto j : cols)
      for (int k = 0; k < 3; ++k)
        c.push_back(3 * j + k);
    return add(r, c, v);
  };
  fem::assemble_matrix(add_blocked, *b.problem->jacobian(),
                       std::vector<std::shared_ptr<const fem::DirichletBC<double>>>{});
  return K;
}

double max_abs(const std::vector<double>& v)
{
  double m = 0;
  for (double x : v)
    m = std::max(m, std::abs(x));
  return m;
}

struct Case
{
  Model model;
  bool passive;
};

class FbarTangent : public ::testing::TestWithParam<Case>
{
};
} // namespace

TEST_P(FbarTangent, IsTheDerivativeOfTheResidual)
{
  int ranks;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  if (ranks > 1)
    GTEST_SKIP() << "dense reference on one rank";
  const Case c = GetParam();
  Body b = make(c.model, true, c.passive);
  set_displacement(b, bent);
  const std::vector<double> K = tangent(b);
  const std::vector<double> u0(b.problem->u()->x()->array().begin(),
                               b.problem->u()->x()->array().end());
  // direction: another smooth field, so every cell's J0 and J vary
  Body d = make(c.model, true, c.passive);
  set_displacement(d, [](double X, double Y, double Z) -> std::array<double, 3>
                   { return {0.3 * Y * Z, std::sin(X - Z), 0.5 * X * X - Y}; });
  const std::vector<double> delta(d.problem->u()->x()->array().begin(),
                                  d.problem->u()->x()->array().end());

  const double h = 1e-6;
  auto residual_at = [&](double s)
  {
    std::span<double> u = b.problem->u()->x()->mutable_array();
    for (std::size_t i = 0; i < u.size(); ++i)
      u[i] = u0[i] + s * delta[i];
    b.problem->update_activation();
    return residual(b);
  };
  const std::vector<double> fd = muscle::testing::central_vector(residual_at, h);
  std::vector<double> Kd(b.size, 0.0);
  for (std::size_t i = 0; i < b.size; ++i)
  {
    for (std::size_t j = 0; j < b.size; ++j)
      Kd[i] += K[i * b.size + j] * delta[j];
  }
  std::vector<double> diff(b.size);
  for (std::size_t i = 0; i < b.size; ++i)
    diff[i] = Kd[i] - fd[i];
  EXPECT_GT(max_abs(fd), 0);
  EXPECT_LT(max_abs(diff), 2e-6 * max_abs(fd)) << to_string(c.model);
  std::printf("%s: |K d - FD| / |FD| = %.2e\n", to_string(c.model).c_str(),
              max_abs(diff) / max_abs(fd));
}

INSTANTIATE_TEST_SUITE_P(Models, FbarTangent,
                         ::testing::Values(Case{Model("combi"), false}, Case{Model("ble"), false},
                                           Case{Model("wkm"), false}, Case{Model("giant"), false},
                                           Case{Model("combi"), true}, Case{Model("ble"), true}),
                         [](const auto& info)
                         {
                           return to_string(info.param.model)
                                  + (info.param.passive ? "_passive" : "");
                         });

TEST(Fbar, EqualsPlainQ1UnderHomogeneousDeformation)
{
  // F = I + H everywhere: J0 = J, F_bar = F (volume change -2.3 %)
  const Field affine = [](double X, double Y, double Z) -> std::array<double, 3>
  { return {0.04 * X + 0.03 * Y - 0.02 * Z, -0.01 * X - 0.05 * Y + 0.02 * Z,
            0.02 * X + 0.01 * Y + 0.04 * Z}; };
  for (Model model : paper_models())
  {
    Body plain = make(model, false), fbar = make(model, true);
    set_displacement(plain, affine);
    set_displacement(fbar, affine);
    const std::vector<double> a = residual(plain), b = residual(fbar);
    std::vector<double> diff(a.size());
    for (std::size_t i = 0; i < a.size(); ++i)
      diff[i] = a[i] - b[i];
    EXPECT_GT(max_abs(a), 1.0) << to_string(model);
    EXPECT_LT(max_abs(diff), 1e-9 * max_abs(a)) << to_string(model);
  }
}

TEST(Fbar, DiffersFromPlainQ1WhenTheVolumeVariesWithinACell)
{
  for (Model model : paper_models())
  {
    Body plain = make(model, false), fbar = make(model, true);
    set_displacement(plain, bent);
    set_displacement(fbar, bent);
    const std::vector<double> a = residual(plain), b = residual(fbar);
    std::vector<double> diff(a.size());
    for (std::size_t i = 0; i < a.size(); ++i)
      diff[i] = a[i] - b[i];
    EXPECT_GT(max_abs(diff), 1e-3 * max_abs(a)) << to_string(model);
    std::printf("%s: |R_fbar - R_Q1| / |R_Q1| = %.2e\n", to_string(model).c_str(),
                max_abs(diff) / max_abs(a));
  }
}

TEST(Fbar, ReferenceStateIsStressFree)
{
  // H_bar is formed from J0 - J, so the undeformed state is as exact as plain
  // Q1's (BLE's passive fibre switch sits at stretch 1): nodal forces are
  // round-off of the reference stress balance only, far below 1 uN
  for (Model model : paper_models())
  {
    Body plain = make(model, false, true), fbar = make(model, true, true);
    const Field zero = [](double, double, double) -> std::array<double, 3>
    { return {0, 0, 0}; };
    set_displacement(plain, zero);
    set_displacement(fbar, zero);
    EXPECT_LT(max_abs(residual(fbar)), 1e-13) << to_string(model);
    EXPECT_LE(max_abs(residual(fbar)), 4 * max_abs(residual(plain)) + 1e-16)
        << to_string(model);
  }
}
