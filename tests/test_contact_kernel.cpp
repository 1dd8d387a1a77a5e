// The contact kernel against finite differences: the residual is the gradient of
// the penalty energy eps/2 g^2 w, the tangent the gradient of the residual, on
// warped quadrilateral and triangular master facets with the slave point
// penetrating, so that Newton converges quadratically once the contact set
// settles.  With averaged corner normals (ContactPair's default) the force acts
// along their interpolation: the tangent is then checked against the residual's
// finite differences with the corner normals held, and the force against its
// closed form.
#include "support/finite_differences.h"

#include <fem/contact/contact_kernel.h>

#include <cmath>
#include <gtest/gtest.h>
#include <random>

using namespace muscle;
using namespace muscle::testing;

namespace
{
struct Configuration
{
  SurfaceFacet slave, master;
  std::array<double, 4> Ns;
};

/// A master facet near z = 0 (outward normal +z), a slave facet just below it.
Configuration random_configuration(std::mt19937& rng, int master_nodes, int slave_nodes)
{
  std::uniform_real_distribution<double> jitter(-0.15, 0.15), unit(0.2, 0.8);
  Configuration c;
  const Point square[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  c.master.n = master_nodes;
  for (int i = 0; i < master_nodes; ++i)
  {
    c.master.node[i] = 10 + i;
    for (int k = 0; k < 3; ++k)
      c.master.x[i][k] = square[i][k] + jitter(rng);
  }
  c.slave.n = slave_nodes;
  for (int i = 0; i < slave_nodes; ++i)
  {
    c.slave.node[i] = i;
    for (int k = 0; k < 3; ++k)
      c.slave.x[i][k] = 0.3 + 0.4 * square[i][k] + 0.3 * jitter(rng);
    c.slave.x[i][2] = -0.05 + 0.2 * jitter(rng);
  }
  const double xi = unit(rng), eta = unit(rng);
  c.Ns = slave_nodes == 4
             ? std::array<double, 4>{(1 - xi) * (1 - eta), xi * (1 - eta), (1 - xi) * eta, xi * eta}
             : std::array<double, 4>{1 - 0.5 * xi - 0.5 * eta, 0.5 * xi, 0.5 * eta, 0};
  return c;
}

/// Node coordinate `dof` of [slave | master] moved by d.
Configuration moved(Configuration c, int dof, double d)
{
  const int node = dof / 3, k = dof % 3;
  if (node < c.slave.n)
    c.slave.x[node][k] += d;
  else
    c.master.x[node - c.slave.n][k] += d;
  return c;
}

/// Orientation that makes the master's a1 x a2 point along +z.
int upward(const SurfaceFacet& f)
{
  const int j2 = f.n == 4 ? 2 : 2;
  const double ax = f.x[1][0] - f.x[0][0], ay = f.x[1][1] - f.x[0][1];
  const double bx = f.x[j2][0] - f.x[0][0], by = f.x[j2][1] - f.x[0][1];
  return ax * by - ay * bx > 0 ? 1 : -1;
}

/// The tangent's column s against central differences of `residual` (a
/// function of the moved configuration), to 1e-5 of the tangent's largest entry.
template <typename R>
void expect_tangent_column(const ContactPoint& p, const Configuration& c, int s, R&& residual,
                           double h)
{
  const int size = static_cast<int>(p.residual.size());
  double K_scale = 0;
  for (double v : p.tangent)
    K_scale = std::max(K_scale, std::abs(v));
  const std::vector<double> dR
      = central_vector([&](double d) { return residual(moved(c, s, d)); }, h);
  for (int r = 0; r < size; ++r)
    EXPECT_NEAR(p.tangent[r * size + s], dR[r], 1e-5 * K_scale) << "K[" << r << "," << s << "]";
}

/// Test names: quad_master_tri_slave, ...
std::string facet_pair_name(const ::testing::TestParamInfo<std::pair<int, int>>& info)
{
  return std::string(info.param.first == 4 ? "quad" : "tri") + "_master_"
         + (info.param.second == 4 ? "quad" : "tri") + "_slave";
}
} // namespace

class ContactKernel : public ::testing::TestWithParam<std::pair<int, int>>
{
};

TEST_P(ContactKernel, ResidualAndTangentAreDerivatives)
{
  const auto [master_nodes, slave_nodes] = GetParam();
  std::mt19937 rng(11 + master_nodes + 10 * slave_nodes);
  const double eps = 1e3, w = 0.25, h = 1e-6;
  int checked = 0;
  for (int trial = 0; trial < 40; ++trial)
  {
    const Configuration c = random_configuration(rng, master_nodes, slave_nodes);
    const int o = upward(c.master);
    const ContactPoint p = contact_point(c.slave, c.Ns, c.master, o, eps, w);
    if (!(p.gap < -1e-3) or p.distance > 0.5)
      continue;
    // the closest point lies inside the facet: away from its edges, where the
    // projection switches facet and g is not twice differentiable
    bool inside = true;
    for (int j = 0; j < master_nodes; ++j)
      inside = inside and p.master_shape[j] > 0.02;
    if (!inside)
      continue;
    ++checked;
    const int size = 3 * (master_nodes + slave_nodes);
    double R_scale = 0;
    for (double v : p.residual)
      R_scale = std::max(R_scale, std::abs(v));
    for (int s = 0; s < size; ++s)
    {
      const double dE = central(
          [&](double d)
          {
            const ContactPoint q = contact_point(moved(c, s, d).slave, c.Ns, moved(c, s, d).master,
                                                 o, eps, w);
            return eps / 2 * q.gap * q.gap * w;
          },
          h);
      EXPECT_NEAR(p.residual[s], dE, 1e-6 * R_scale) << "R[" << s << "]";
      expect_tangent_column(
          p, c, s,
          [&](const Configuration& m)
          { return contact_point(m.slave, c.Ns, m.master, o, eps, w).residual; },
          h);
    }
  }
  EXPECT_GT(checked, 10);
}

INSTANTIATE_TEST_SUITE_P(Facets, ContactKernel,
                         ::testing::Values(std::pair{4, 4}, std::pair{3, 4}, std::pair{4, 3},
                                           std::pair{3, 3}),
                         facet_pair_name);

TEST(ContactKernel, SeparatedPointsCarryNothing)
{
  std::mt19937 rng(3);
  Configuration c = random_configuration(rng, 4, 4);
  for (auto& x : c.slave.x)
    x[2] += 1.0; // above the master
  const ContactPoint p = contact_point(c.slave, c.Ns, c.master, upward(c.master), 1e3, 1);
  EXPECT_GT(p.gap, 0);
  EXPECT_TRUE(p.residual.empty());
}

class SmoothNormalKernel : public ::testing::TestWithParam<std::pair<int, int>>
{
};

TEST_P(SmoothNormalKernel, TangentIsTheResidualsDerivative)
{
  const auto [master_nodes, slave_nodes] = GetParam();
  std::mt19937 rng(7 + master_nodes + 10 * slave_nodes);
  std::uniform_real_distribution<double> tilt(-0.3, 0.3);
  const double eps = 1e3, w = 0.25, h = 1e-6;
  int checked = 0;
  for (int trial = 0; trial < 40; ++trial)
  {
    const Configuration c = random_configuration(rng, master_nodes, slave_nodes);
    const int o = upward(c.master);
    // corner normals tilted away from +z, as on a curved surface
    std::array<Point, 4> corners{};
    for (int j = 0; j < master_nodes; ++j)
    {
      Point v = {tilt(rng), tilt(rng), 1};
      const double l = std::sqrt(dot(v, v));
      for (double& x : v)
        x /= l;
      corners[j] = v;
    }
    const ContactPoint p = contact_point(c.slave, c.Ns, c.master, o, eps, w, &corners);
    const ContactPoint exact = contact_point(c.slave, c.Ns, c.master, o, eps, w);
    if (!(p.gap < -1e-3) or p.distance > 0.5)
      continue;
    bool inside = true;
    for (int j = 0; j < master_nodes; ++j)
      inside = inside and p.master_shape[j] > 0.02;
    if (!inside)
      continue;
    ++checked;
    // the gap is the facet's; the force eps w g along nu = sum N_j n_j / |...|
    EXPECT_DOUBLE_EQ(p.gap, exact.gap);
    Point nu{};
    for (int j = 0; j < master_nodes; ++j)
      for (int k = 0; k < 3; ++k)
        nu[k] += p.master_shape[j] * corners[j][k];
    const double l = std::sqrt(dot(nu, nu));
    for (int k = 0; k < 3; ++k)
    {
      double on_slave = 0;
      for (int i = 0; i < slave_nodes; ++i)
        on_slave += p.residual[3 * i + k];
      EXPECT_NEAR(on_slave, eps * w * p.gap * nu[k] / l, 1e-12 * eps);
    }
    const int size = 3 * (master_nodes + slave_nodes);
    for (int s = 0; s < size; ++s)
    {
      expect_tangent_column(
          p, c, s,
          [&](const Configuration& m)
          { return contact_point(m.slave, c.Ns, m.master, o, eps, w, &corners).residual; },
          h);
    }
  }
  EXPECT_GT(checked, 10);
}

INSTANTIATE_TEST_SUITE_P(Facets, SmoothNormalKernel,
                         ::testing::Values(std::pair{4, 4}, std::pair{3, 4}, std::pair{4, 3},
                                           std::pair{3, 3}),
                         facet_pair_name);
