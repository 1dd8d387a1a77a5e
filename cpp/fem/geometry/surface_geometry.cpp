#include "fem/geometry/surface_geometry.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace muscle
{
namespace
{
Point scaled(const Point& a, double s) { return {s * a[0], s * a[1], s * a[2]}; }
Point normalised(const Point& a) { return scaled(a, 1 / std::sqrt(dot(a, a))); }

using Point2 = std::array<double, 2>;
using Polygon = std::vector<Point2>;

double cross2(const Point2& a, const Point2& b, const Point2& c)
{
  return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

double signed_area(const Polygon& p)
{
  double a = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
  {
    const Point2& u = p[i];
    const Point2& v = p[(i + 1) % p.size()];
    a += u[0] * v[1] - v[0] * u[1];
  }
  return a / 2;
}

/// Sutherland-Hodgman: `subject` clipped by the convex, counter-clockwise `clip`.
Polygon clip(Polygon subject, const Polygon& clip)
{
  for (std::size_t e = 0; e < clip.size() and !subject.empty(); ++e)
  {
    const Point2 a = clip[e], b = clip[(e + 1) % clip.size()];
    Polygon out;
    for (std::size_t i = 0; i < subject.size(); ++i)
    {
      const Point2 p = subject[i], q = subject[(i + 1) % subject.size()];
      const double dp = cross2(a, b, p), dq = cross2(a, b, q);
      if (dp >= 0)
        out.push_back(p);
      if ((dp >= 0) != (dq >= 0))
      {
        const double t = dp / (dp - dq);
        out.push_back({p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])});
      }
    }
    subject = out;
  }
  return subject;
}

/// Boundary (cyclic) order of a facet's nodes: tensor order 0 1 3 2 for quadrilaterals.
std::vector<int> cyclic(const SurfaceFacet& f)
{
  return f.n == 4 ? std::vector<int>{0, 1, 3, 2} : std::vector<int>{0, 1, 2};
}

/// Shape functions at (xi, eta): tensor-order bilinear, or linear on the triangle.
std::array<double, 4> shape(int n, double xi, double eta)
{
  if (n == 4)
    return {(1 - xi) * (1 - eta), xi * (1 - eta), (1 - xi) * eta, xi * eta};
  return {1 - xi - eta, xi, eta, 0};
}

/// The dual basis coefficients A (psi_i = sum_j A_ij N_j) of a slave facet:
/// A = D M^-1, M the facet's mass matrix, D its row sums.
Eigen::Matrix4d dual_basis(const SurfaceFacet& f)
{
  const int n = f.n;
  Eigen::Matrix4d M = Eigen::Matrix4d::Zero();
  // 3 x 3 Gauss on the square, or the degree-4 rule on the triangle via collapse
  const double g[3] = {0.5 - std::sqrt(0.15), 0.5, 0.5 + std::sqrt(0.15)};
  const double w[3] = {5.0 / 18, 8.0 / 18, 5.0 / 18};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
    {
      double xi = g[i], eta = g[j], weight = w[i] * w[j];
      if (n == 3)
      {
        // Duffy: (xi, eta) = (u, v (1 - u)), dA = (1 - u)
        eta = g[j] * (1 - g[i]);
        weight *= 1 - g[i];
      }
      const std::array<double, 4> N = shape(n, xi, eta);
      Point a{}, b{};
      const std::array<double, 4> dxi
          = n == 4 ? std::array<double, 4>{-(1 - eta), 1 - eta, -eta, eta}
                   : std::array<double, 4>{-1, 1, 0, 0};
      const std::array<double, 4> deta
          = n == 4 ? std::array<double, 4>{-(1 - xi), -xi, 1 - xi, xi}
                   : std::array<double, 4>{-1, 0, 1, 0};
      for (int k = 0; k < n; ++k)
        for (int d = 0; d < 3; ++d)
        {
          a[d] += dxi[k] * f.x[k][d];
          b[d] += deta[k] * f.x[k][d];
        }
      const Point c = cross(a, b);
      const double dA = std::sqrt(dot(c, c)) * weight;
      for (int r = 0; r < n; ++r)
        for (int s = 0; s < n; ++s)
          M(r, s) += N[r] * N[s] * dA;
    }
  if (n == 3)
    M(3, 3) = 1;
  Eigen::Matrix4d D = Eigen::Matrix4d::Zero();
  for (int r = 0; r < n; ++r)
    D(r, r) = M.row(r).head(n).sum();
  if (n == 3)
    D(3, 3) = 0;
  return D * M.inverse();
}
} // namespace

Point facet_centre(const SurfaceFacet& f)
{
  Point c{};
  for (int i = 0; i < f.n; ++i)
    for (int k = 0; k < 3; ++k)
      c[k] += f.x[i][k] / f.n;
  return c;
}

Point facet_normal(const SurfaceFacet& f)
{
  return cross(sub(f.x[1], f.x[0]), sub(f.x[2], f.x[0]));
}

void tensor_order(SurfaceFacet& f)
{
  if (f.n != 4)
    return;
  int far = 1;
  for (int k = 2; k < 4; ++k)
    if (dot(sub(f.x[k], f.x[0]), sub(f.x[k], f.x[0]))
        > dot(sub(f.x[far], f.x[0]), sub(f.x[far], f.x[0])))
      far = k;
  std::swap(f.x[far], f.x[3]);
  std::swap(f.node[far], f.node[3]);
}

std::pair<double, std::array<double, 4>> closest_point(const SurfaceFacet& f, const Point& p)
{
  std::array<double, 4> w{};
  if (f.n == 3)
  {
    // Ericson, Real-Time Collision Detection 5.1.5
    const Point ab = sub(f.x[1], f.x[0]), ac = sub(f.x[2], f.x[0]), ap = sub(p, f.x[0]);
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    const Point bp = sub(p, f.x[1]), cp = sub(p, f.x[2]);
    const double d3 = dot(ab, bp), d4 = dot(ac, bp), d5 = dot(ab, cp), d6 = dot(ac, cp);
    const double va = d3 * d6 - d5 * d4, vb = d5 * d2 - d1 * d6, vc = d1 * d4 - d3 * d2;
    if (d1 <= 0 and d2 <= 0)
      w = {1, 0, 0, 0};
    else if (d3 >= 0 and d4 <= d3)
      w = {0, 1, 0, 0};
    else if (d6 >= 0 and d5 <= d6)
      w = {0, 0, 1, 0};
    else if (vc <= 0 and d1 >= 0 and d3 <= 0)
    {
      const double v = d1 / (d1 - d3);
      w = {1 - v, v, 0, 0};
    }
    else if (vb <= 0 and d2 >= 0 and d6 <= 0)
    {
      const double v = d2 / (d2 - d6);
      w = {1 - v, 0, v, 0};
    }
    else if (va <= 0 and (d4 - d3) >= 0 and (d5 - d6) >= 0)
    {
      const double v = (d4 - d3) / ((d4 - d3) + (d5 - d6));
      w = {0, 1 - v, v, 0};
    }
    else
    {
      const double s = 1 / (va + vb + vc), v = vb * s, t = vc * s;
      w = {1 - v - t, v, t, 0};
    }
  }
  else
  {
    double xi = 0.5, eta = 0.5;
    for (int it = 0; it < 30; ++it)
    {
      const std::array<double, 4> N = shape(4, xi, eta);
      const std::array<double, 4> dxi = {-(1 - eta), 1 - eta, -eta, eta};
      const std::array<double, 4> deta = {-(1 - xi), -xi, 1 - xi, xi};
      Point r{}, a{}, b{};
      for (int i = 0; i < 4; ++i)
        for (int k = 0; k < 3; ++k)
        {
          r[k] += N[i] * f.x[i][k];
          a[k] += dxi[i] * f.x[i][k];
          b[k] += deta[i] * f.x[i][k];
        }
      r = sub(r, p);
      const double aa = dot(a, a), ab = dot(a, b), bb = dot(b, b);
      const double ra = dot(r, a), rb = dot(r, b), det = aa * bb - ab * ab;
      if (!(det > 0))
        break;
      const double dx = -(bb * ra - ab * rb) / det, de = -(aa * rb - ab * ra) / det;
      xi = std::clamp(xi + dx, 0.0, 1.0);
      eta = std::clamp(eta + de, 0.0, 1.0);
      if (std::abs(dx) + std::abs(de) < 1e-15)
        break;
    }
    w = shape(4, xi, eta);
  }
  Point q{};
  for (int i = 0; i < f.n; ++i)
    for (int k = 0; k < 3; ++k)
      q[k] += w[i] * f.x[i][k];
  const Point d = sub(q, p);
  return {std::sqrt(dot(d, d)), w};
}

std::vector<std::tuple<std::int64_t, std::int64_t, double>>
dual_mortar(const std::vector<SurfaceFacet>& slave, const std::vector<SurfaceFacet>& master,
            double distance)
{
  // Dunavant's 7-point rule, degree 5 (barycentric a, b; weight of a unit-area triangle)
  static const double rule[7][3]
      = {{1.0 / 3, 1.0 / 3, 0.225},
         {0.059715871789770, 0.470142064105115, 0.132394152788506},
         {0.470142064105115, 0.059715871789770, 0.132394152788506},
         {0.470142064105115, 0.470142064105115, 0.132394152788506},
         {0.797426985353087, 0.101286507323456, 0.125939180544827},
         {0.101286507323456, 0.797426985353087, 0.125939180544827},
         {0.101286507323456, 0.101286507323456, 0.125939180544827}};
  auto centre_radius = [](const SurfaceFacet& f)
  {
    Point c{};
    for (int i = 0; i < f.n; ++i)
      for (int k = 0; k < 3; ++k)
        c[k] += f.x[i][k] / f.n;
    double r = 0;
    for (int i = 0; i < f.n; ++i)
      r = std::max(r, std::sqrt(dot(sub(f.x[i], c), sub(f.x[i], c))));
    return std::pair{c, r};
  };
  std::vector<std::pair<Point, double>> master_spheres;
  for (const SurfaceFacet& f : master)
    master_spheres.push_back(centre_radius(f));

  std::vector<std::tuple<std::int64_t, std::int64_t, double>> out;
  for (const SurfaceFacet& e : slave)
  {
    const Eigen::Matrix4d A = dual_basis(e);
    const auto [c, r] = centre_radius(e);
    const Point normal = e.n == 4 ? normalised(cross(sub(e.x[3], e.x[0]), sub(e.x[2], e.x[1])))
                                  : normalised(cross(sub(e.x[1], e.x[0]), sub(e.x[2], e.x[0])));
    const Point t1 = normalised(sub(sub(e.x[1], e.x[0]),
                                    scaled(normal, dot(sub(e.x[1], e.x[0]), normal))));
    const Point t2 = cross(normal, t1);
    auto plane = [&](const Point& x) -> Point2
    { return {dot(sub(x, c), t1), dot(sub(x, c), t2)}; };
    Polygon slave_polygon;
    for (int i : cyclic(e))
      slave_polygon.push_back(plane(e.x[i]));
    if (signed_area(slave_polygon) < 0)
      std::reverse(slave_polygon.begin(), slave_polygon.end());

    for (std::size_t m = 0; m < master.size(); ++m)
    {
      const SurfaceFacet& f = master[m];
      const auto& [cm, rm] = master_spheres[m];
      if (std::sqrt(dot(sub(cm, c), sub(cm, c))) > r + rm + distance)
        continue;
      Polygon master_polygon;
      for (int i : cyclic(f))
        master_polygon.push_back(plane(f.x[i]));
      if (signed_area(master_polygon) < 0)
        std::reverse(master_polygon.begin(), master_polygon.end());
      const Polygon overlap = clip(master_polygon, slave_polygon);
      if (overlap.size() < 3 or std::abs(signed_area(overlap)) < 1e-14 * r * r)
        continue;
      Point2 centre{0, 0};
      for (const Point2& p : overlap)
        centre = {centre[0] + p[0] / overlap.size(), centre[1] + p[1] / overlap.size()};
      std::array<std::array<double, 4>, 4> integral{}; // [slave i][master k]
      for (std::size_t t = 0; t < overlap.size(); ++t)
      {
        const Point2 &p1 = overlap[t], &p2 = overlap[(t + 1) % overlap.size()];
        const double area = std::abs(cross2(centre, p1, p2)) / 2;
        for (const auto& q : rule)
        {
          const double l3 = 1 - q[0] - q[1];
          const Point2 y = {q[0] * centre[0] + q[1] * p1[0] + l3 * p2[0],
                            q[0] * centre[1] + q[1] * p1[1] + l3 * p2[1]};
          const Point x = {c[0] + y[0] * t1[0] + y[1] * t2[0], c[1] + y[0] * t1[1] + y[1] * t2[1],
                           c[2] + y[0] * t1[2] + y[1] * t2[2]};
          const std::array<double, 4> Ns = closest_point(e, x).second;
          const std::array<double, 4> Nm = closest_point(f, x).second;
          for (int i = 0; i < e.n; ++i)
          {
            double psi = 0;
            for (int j = 0; j < e.n; ++j)
              psi += A(i, j) * Ns[j];
            for (int k = 0; k < f.n; ++k)
              integral[i][k] += q[2] * area * psi * Nm[k];
          }
        }
      }
      for (int i = 0; i < e.n; ++i)
        for (int k = 0; k < f.n; ++k)
          out.emplace_back(e.node[i], f.node[k], integral[i][k]);
    }
  }
  return out;
}

} // namespace muscle
