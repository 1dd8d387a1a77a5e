#include "fem/contact/contact_kernel.h"

#include <cmath>

namespace muscle
{
void facet_derivatives(const SurfaceFacet& f, const std::array<double, 4>& N,
                       std::array<double, 4>& d1, std::array<double, 4>& d2,
                       std::array<double, 4>& d12)
{
  if (f.n == 3)
  {
    d1 = {-1, 1, 0, 0};
    d2 = {-1, 0, 1, 0};
    d12 = {0, 0, 0, 0};
    return;
  }
  // tensor order: N1 = xi (1 - eta), N3 = xi eta, N2 = (1 - xi) eta
  const double xi = N[1] + N[3], eta = N[2] + N[3];
  d1 = {-(1 - eta), 1 - eta, -eta, eta};
  d2 = {-(1 - xi), -xi, 1 - xi, xi};
  d12 = {1, -1, -1, 1};
}

ContactPoint contact_point(const SurfaceFacet& slave, const std::array<double, 4>& Ns,
                           const SurfaceFacet& master, int orientation, double eps,
                           double weight, const std::array<Point, 4>* corner_normals)
{
  ContactPoint c;
  Point xs{};
  for (int i = 0; i < slave.n; ++i)
    for (int k = 0; k < 3; ++k)
      xs[k] += Ns[i] * slave.x[i][k];
  const auto [distance, Nm] = closest_point(master, xs);
  c.distance = distance;
  c.master_shape = Nm;
  std::array<double, 4> d1, d2, d12;
  facet_derivatives(master, Nm, d1, d2, d12);
  Point xm{}, a1{}, a2{}, a12{};
  for (int j = 0; j < master.n; ++j)
    for (int k = 0; k < 3; ++k)
    {
      xm[k] += Nm[j] * master.x[j][k];
      a1[k] += d1[j] * master.x[j][k];
      a2[k] += d2[j] * master.x[j][k];
      a12[k] += d12[j] * master.x[j][k];
    }
  Point n = cross(a1, a2);
  const double length = std::sqrt(dot(n, n));
  for (double& v : n)
    v *= orientation / length;
  const Point d = {xs[0] - xm[0], xs[1] - xm[1], xs[2] - xm[2]};
  c.gap = dot(d, n);
  // nu = nu^ / |nu^|, nu^ = sum N_j nu_j: the force's direction with corner normals
  Point nh{}, nu = n;
  double nl = 1;
  if (corner_normals)
  {
    for (int j = 0; j < master.n; ++j)
      for (int k = 0; k < 3; ++k)
        nh[k] += Nm[j] * (*corner_normals)[j][k];
    nl = std::sqrt(dot(nh, nh));
    for (int k = 0; k < 3; ++k)
      nu[k] = nh[k] / nl;
  }
  c.normal = nu;
  if (c.gap > 0)
    return c;

  const int ns = slave.n, nm = master.n, size = 3 * (ns + nm);
  // dg/du and the vectors of its second derivative, on [slave | master] dofs
  std::vector<double> Nv(size, 0), T1(size, 0), T2(size, 0), N1(size, 0), N2(size, 0);
  for (int i = 0; i < ns; ++i)
    for (int k = 0; k < 3; ++k)
    {
      Nv[3 * i + k] = Ns[i] * n[k];
      T1[3 * i + k] = Ns[i] * a1[k];
      T2[3 * i + k] = Ns[i] * a2[k];
    }
  for (int j = 0; j < nm; ++j)
    for (int k = 0; k < 3; ++k)
    {
      const int r = 3 * (ns + j) + k;
      Nv[r] = -Nm[j] * n[k];
      T1[r] = -Nm[j] * a1[k];
      T2[r] = -Nm[j] * a2[k];
      N1[r] = d1[j] * n[k];
      N2[r] = d2[j] * n[k];
    }
  const double g = c.gap;
  const double m11 = dot(a1, a1), m12 = dot(a1, a2), m22 = dot(a2, a2);
  const double k12 = dot(n, a12);
  // A = m - g kappa; D = A^-1 (T + g N): the closest point's motion dxi/du
  const double A11 = m11, A12 = m12 - g * k12, A22 = m22, detA = A11 * A22 - A12 * A12;
  const double detm = m11 * m22 - m12 * m12;
  const double mi11 = m22 / detm, mi12 = -m12 / detm, mi22 = m11 / detm;
  std::vector<double> D1(size), D2(size), MT1(size), MT2(size);
  for (int r = 0; r < size; ++r)
  {
    const double b1 = T1[r] + g * N1[r], b2 = T2[r] + g * N2[r];
    D1[r] = (A22 * b1 - A12 * b2) / detA;
    D2[r] = (A11 * b2 - A12 * b1) / detA;
    MT1[r] = mi11 * T1[r] + mi12 * T2[r]; // m^{1 gamma} T_gamma
    MT2[r] = mi12 * T1[r] + mi22 * T2[r];
  }
  c.residual.assign(size, 0);
  c.tangent.assign(size * size, 0);
  const double f = eps * weight;
  if (corner_normals)
  {
    // dnu/dxi_a = (I - nu nu) dnu^/dxi_a / |nu^|
    Point dh1{}, dh2{}, dnu1, dnu2;
    for (int j = 0; j < nm; ++j)
      for (int k = 0; k < 3; ++k)
      {
        dh1[k] += d1[j] * (*corner_normals)[j][k];
        dh2[k] += d2[j] * (*corner_normals)[j][k];
      }
    const double p1 = dot(nu, dh1), p2 = dot(nu, dh2);
    for (int k = 0; k < 3; ++k)
    {
      dnu1[k] = (dh1[k] - p1 * nu[k]) / nl;
      dnu2[k] = (dh2[k] - p2 * nu[k]) / nl;
    }
    // force direction on [slave | master] dofs and its derivative along dxi/du
    std::vector<double> Fv(size), F1(size), F2(size);
    for (int i = 0; i < ns; ++i)
      for (int k = 0; k < 3; ++k)
      {
        Fv[3 * i + k] = Ns[i] * nu[k];
        F1[3 * i + k] = Ns[i] * dnu1[k];
        F2[3 * i + k] = Ns[i] * dnu2[k];
      }
    for (int j = 0; j < nm; ++j)
      for (int k = 0; k < 3; ++k)
      {
        const int r = 3 * (ns + j) + k;
        Fv[r] = -Nm[j] * nu[k];
        F1[r] = -d1[j] * nu[k] - Nm[j] * dnu1[k];
        F2[r] = -d2[j] * nu[k] - Nm[j] * dnu2[k];
      }
    for (int r = 0; r < size; ++r)
    {
      c.residual[r] = f * g * Fv[r];
      for (int s = 0; s < size; ++s)
        c.tangent[r * size + s] = f * (Fv[r] * Nv[s] + g * (F1[r] * D1[s] + F2[r] * D2[s]));
    }
    return c;
  }
  for (int r = 0; r < size; ++r)
  {
    c.residual[r] = f * g * Nv[r];
    for (int s = 0; s < size; ++s)
    {
      // d2g = -N_a (x) D_a - m^{ag} T_g (x) N_a - m^{ag} kappa_ab T_g (x) D_b
      const double G = -(N1[r] * D1[s] + N2[r] * D2[s]) - (MT1[r] * N1[s] + MT2[r] * N2[s])
                       - k12 * (MT1[r] * D2[s] + MT2[r] * D1[s]);
      c.tangent[r * size + s] = f * (Nv[r] * Nv[s] + g * G);
    }
  }
  return c;
}

} // namespace muscle
