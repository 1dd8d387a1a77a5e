#include "fem/contact/contact.h"

#include "common/errors.h"
#include "fem/geometry/gather.h"
#include "fem/contact/contact_kernel.h"

#include <algorithm>
#include <cmath>
#include <dolfinx/common/IndexMap.h>
#include <dolfinx/common/MPI.h>
#include <dolfinx/fem/DofMap.h>
#include <dolfinx/mesh/Mesh.h>
#include <nanoflann.hpp>
#include <numeric>
#include <unordered_map>
#include <petscvec.h>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// Master facet centres as nanoflann reads them.
struct MasterCentres
{
  std::vector<Point> points;
  std::size_t kdtree_get_point_count() const { return points.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return points[i][d]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const
  {
    return false;
  }
};
using CentreTree = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Simple_Adaptor<double, MasterCentres>, MasterCentres, 3>;
} // namespace

ContactPair::ContactPair(std::shared_ptr<const fem::Function<double>> u, Settings settings,
                         const std::vector<std::int32_t>& fixed)
    : _u(std::move(u)), _settings(std::move(settings))
{
  MPI_Comm comm = _u->function_space()->mesh()->comm();
  _slave = owned_surface_facets(*_u->function_space(), _settings.slave, _settings.name);
  _master = owned_surface_facets(*_u->function_space(), _settings.master, _settings.name);
  std::int64_t counts[2] = {std::int64_t(_slave.size()), std::int64_t(_master.size())};
  MPI_Allreduce(MPI_IN_PLACE, counts, 2, MPI_INT64_T, MPI_SUM, comm);
  if (counts[0] == 0 or counts[1] == 0)
    throw InputError(_settings.name + ": the " + (counts[0] == 0 ? "slave" : "master")
                     + " surface has no boundary facets");

  // 3 x 3 Gauss points per quadrilateral, the same collapsed onto triangles
  const double g[3] = {0.5 - std::sqrt(0.15), 0.5, 0.5 + std::sqrt(0.15)};
  const double w[3] = {5.0 / 18, 8.0 / 18, 5.0 / 18};
  for (std::size_t e = 0; e < _slave.size(); ++e)
  {
    const SurfaceFacet& f = _slave[e].reference;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
      {
        double xi = g[i], eta = g[j], weight = w[i] * w[j];
        if (f.n == 3)
        {
          eta = g[j] * (1 - g[i]);
          weight *= 1 - g[i];
        }
        const std::array<double, 4> N
            = f.n == 4 ? std::array<double, 4>{(1 - xi) * (1 - eta), xi * (1 - eta),
                                               (1 - xi) * eta, xi * eta}
                       : std::array<double, 4>{1 - xi - eta, xi, eta, 0};
        std::array<double, 4> d1, d2, d12;
        facet_derivatives(f, N, d1, d2, d12);
        Point a{}, b{};
        for (int k = 0; k < f.n; ++k)
          for (int c = 0; c < 3; ++c)
          {
            a[c] += d1[k] * f.x[k][c];
            b[c] += d2[k] * f.x[k][c];
          }
        const Point n = cross(a, b);
        _points.push_back({e, N, std::sqrt(dot(n, n)) * weight});
      }
  }

  auto x = _u->x();
  _fixed.assign(x->array().size(), 0);
  for (std::int32_t d : fixed)
    _fixed[d] = 1;

  // do the surfaces face each other anywhere?  (reference configuration)
  const std::vector<Master> master = gather_master();
  int faces = 0;
  for (const Facet& s : _slave)
  {
    const Point c = facet_centre(s.reference);
    double best = std::numeric_limits<double>::infinity();
    const Master* nearest = nullptr;
    Point closest{};
    for (const Master& m : master)
      if (const auto [d, N] = closest_point(m.current, c); d < best)
      {
        best = d;
        nearest = &m;
        closest = {};
        for (int k = 0; k < m.current.n; ++k)
          for (int j = 0; j < 3; ++j)
            closest[j] += N[k] * m.current.x[k][j];
      }
    if (!nearest)
      continue;
    // opposite normals, and the master on the slave's outer side (or touching)
    const Point ns = facet_normal(s.reference);
    const double scale = std::sqrt(dot(ns, ns));
    if (dot(ns, facet_normal(nearest->current)) * s.orientation * nearest->orientation < 0
        and dot(sub(closest, c), ns) * s.orientation > -1e-6 * scale)
      faces = 1;
  }
  MPI_Allreduce(MPI_IN_PLACE, &faces, 1, MPI_INT, MPI_MAX, comm);
  if (!faces)
    throw InputError(_settings.name + ": the surfaces never face each other (every slave facet's "
                     "outward normal points the same way as the nearest master facet's): "
                     "contact needs two surfaces of bodies that can touch");
}

SurfaceFacet ContactPair::current(const Facet& f) const
{
  SurfaceFacet c = f.reference;
  const std::span<const double> u = _u->x()->array();
  for (int k = 0; k < c.n; ++k)
    for (int d = 0; d < 3; ++d)
      c.x[k][d] += u[3 * f.block[k] + d];
  return c;
}

std::vector<ContactPair::Master> ContactPair::gather_master() const
{
  // n, orientation, then per node x, y, z, global node, fixed flags (bits)
  std::vector<double> packed;
  for (const Facet& f : _master)
  {
    const SurfaceFacet c = current(f);
    packed.insert(packed.end(), {double(c.n), double(f.orientation)});
    for (int k = 0; k < c.n; ++k)
    {
      const std::int32_t b = f.block[k];
      const double bits = _fixed[3 * b] + 2 * _fixed[3 * b + 1] + 4 * _fixed[3 * b + 2];
      packed.insert(packed.end(), {c.x[k][0], c.x[k][1], c.x[k][2], double(c.node[k]), bits});
    }
  }
  const std::vector<double> all
      = gather_all(_u->function_space()->mesh()->comm(), packed);
  std::vector<Master> out;
  for (std::size_t i = 0; i < all.size();)
  {
    Master m;
    m.current.n = static_cast<int>(all[i]);
    m.orientation = static_cast<int>(all[i + 1]);
    i += 2;
    for (int k = 0; k < m.current.n; ++k, i += 5)
    {
      m.current.x[k] = {all[i], all[i + 1], all[i + 2]};
      m.current.node[k] = static_cast<std::int64_t>(all[i + 3]);
      const int bits = static_cast<int>(all[i + 4]);
      for (int d = 0; d < 3; ++d)
        m.fixed[3 * k + d] = bits & (1 << d);
    }
    out.push_back(m);
  }

  // corner normals: facets around each node within the feature angle
  const double feature = std::cos(45.0 * M_PI / 180);
  std::vector<Point> normal(out.size());
  std::unordered_map<std::int64_t, std::vector<std::size_t>> around;
  for (std::size_t f = 0; f < out.size(); ++f)
  {
    normal[f] = facet_normal(out[f].current); // length: area (x 2 for triangles)
    for (double& v : normal[f])
      v *= out[f].orientation;
    for (int k = 0; k < out[f].current.n; ++k)
      around[out[f].current.node[k]].push_back(f);
  }
  auto unit = [](Point v)
  {
    const double l = std::sqrt(dot(v, v));
    for (double& x : v)
      x /= l;
    return v;
  };
  for (std::size_t f = 0; f < out.size(); ++f)
  {
    const Point nf = unit(normal[f]);
    for (int k = 0; k < out[f].current.n; ++k)
    {
      Point sum{};
      for (std::size_t g : around[out[f].current.node[k]])
        if (dot(unit(normal[g]), nf) >= feature)
        {
          for (int c = 0; c < 3; ++c)
            sum[c] += normal[g][c];
          out[f].ring[k].push_back(g);
        }
      out[f].corner_length[k] = std::sqrt(dot(sum, sum));
      out[f].corner_normal[k] = unit(sum);
    }
  }
  return out;
}

template <typename F>
void ContactPair::for_each_contact(F&& f, bool with_open)
{
  _gathered = gather_master();
  const std::vector<Master>& master = _gathered;
  // bounding spheres of the master facets, and a k-d tree over their centres
  MasterCentres centres;
  std::vector<double> radius;
  double largest = 0;
  for (const Master& m : master)
  {
    const Point c = facet_centre(m.current);
    double r = 0;
    for (int k = 0; k < m.current.n; ++k)
      r = std::max(r, std::sqrt(dot(sub(m.current.x[k], c), sub(m.current.x[k], c))));
    centres.points.push_back(c);
    radius.push_back(r);
    largest = std::max(largest, r);
  }
  const CentreTree tree(3, centres);
  std::vector<SurfaceFacet> slave(_slave.size());
  for (std::size_t e = 0; e < _slave.size(); ++e)
    slave[e] = current(_slave[e]);
  const double reach = _settings.search_distance;
  std::vector<std::pair<unsigned int, double>> found; // nanoflann 1.4: unsigned indices
  for (const QuadraturePoint& q : _points)
  {
    const SurfaceFacet& s = slave[q.facet];
    Point xs{};
    for (int i = 0; i < s.n; ++i)
      for (int k = 0; k < 3; ++k)
        xs[k] += q.N[i] * s.x[i][k];
    double best = std::numeric_limits<double>::infinity();
    std::size_t nearest = master.size();
    // candidates: facets whose centre lies within the largest radius + reach
    // (squared distances), visited in facet order so that ties go as before
    found.clear();
    const double search = largest + reach;
    tree.radiusSearch(xs.data(), search * search * (1 + 1e-12), found,
                      nanoflann::SearchParams(32, 0, false));
    std::sort(found.begin(), found.end());
    for (const auto& [m, d2] : found)
    {
      const Point d = sub(centres.points[m], xs);
      if (std::sqrt(dot(d, d)) > radius[m] + reach)
        continue;
      if (const double dist = closest_point(master[m].current, xs).first; dist < best)
      {
        best = dist;
        nearest = m;
      }
    }
    if (nearest == master.size() or best > reach)
      continue;
    const Master& m = master[nearest];
    const ContactPoint p
        = contact_point(s, q.N, m.current, m.orientation, _settings.penalty, q.weight,
                        _settings.smooth_normals ? &m.corner_normal : nullptr);
    // only a slave surface that faces the master: not the far side of a thin body
    // g = 0 counts: bodies that just touch keep the contact stiffness (a block
    // resting on another is held in place from the first iteration)
    if ((p.gap > 0 and !with_open)
        or dot(facet_normal(s), p.normal) * _slave[q.facet].orientation > 0)
      continue;
    // a point beyond the master's edge projects onto the edge, not along the normal
    if (p.distance * p.distance - p.gap * p.gap > 1e-12 * reach * reach)
      continue;
    f(q, _slave[q.facet], m, p);
  }
}

std::vector<PetscInt> ContactPair::global_dofs(const Facet& s, const Master& m) const
{
  std::vector<PetscInt> dofs;
  for (int i = 0; i < s.reference.n; ++i)
    for (int d = 0; d < 3; ++d)
      dofs.push_back(_fixed[3 * s.block[i] + d] ? -1 : 3 * s.reference.node[i] + d);
  for (int j = 0; j < m.current.n; ++j)
    for (int d = 0; d < 3; ++d)
      dofs.push_back(m.fixed[3 * j + d] ? -1 : 3 * m.current.node[j] + d);
  return dofs;
}

void ContactPair::add_residual(Vec F)
{
  std::int64_t active = 0;
  for_each_contact(
      [&](const QuadraturePoint&, const Facet& s, const Master& m, const ContactPoint& p)
      {
        ++active;
        const std::vector<PetscInt> rows = global_dofs(s, m);
        VecSetValues(F, rows.size(), rows.data(), p.residual.data(), ADD_VALUES);
      });
  const std::int64_t previous = _active;
  MPI_Allreduce(&active, &_active, 1, MPI_INT64_T, MPI_SUM,
                _u->function_space()->mesh()->comm());
  _previous_active = previous;
  _changed = _evaluations++ == 0 ? 0 : std::abs(_active - previous);
}

void ContactPair::add_jacobian(Mat A)
{
  for_each_contact(
      [&](const QuadraturePoint& q, const Facet& s, const Master& m, const ContactPoint& p)
      {
        const std::vector<PetscInt> dofs = global_dofs(s, m);
        MatSetValues(A, dofs.size(), dofs.data(), dofs.size(), dofs.data(), p.tangent.data(),
                     ADD_VALUES);
        if (_settings.smooth_normals)
          add_normal_motion(A, q, dofs, m, p);
      });
}

namespace
{
/// [v]_x: [v]_x w = v x w
std::array<double, 9> skew(const Point& v)
{
  return {0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0};
}
} // namespace

void ContactPair::add_normal_motion(Mat A, const QuadraturePoint& q,
                                    const std::vector<PetscInt>& rows, const Master& m,
                                    const ContactPoint& p)
{
  // The force eps w g nu, nu = nu^ / |nu^|, nu^ = sum_j N_j nu_j, moves with the
  // corner normals nu_j = s_j / |s_j|, s_j the oriented (area-weighted) normals
  // c_f = (x1 - x0) x (x2 - x0) of the facets around corner j: the part of the
  // tangent contact_kernel.h leaves out.  dc = [a]_x db - [b]_x da.
  const std::vector<Master>& all = _gathered;
  const Point& nu = p.normal;
  Point nh{};
  for (int j = 0; j < m.current.n; ++j)
    for (int k = 0; k < 3; ++k)
      nh[k] += p.master_shape[j] * m.corner_normal[j][k];
  const double L = std::sqrt(dot(nh, nh));
  // d nu / d x_node (3 x 3) per global node of the rings
  std::unordered_map<std::int64_t, std::array<double, 9>> dnu;
  std::unordered_map<std::int64_t, std::array<bool, 3>> fixed;
  for (int j = 0; j < m.current.n; ++j)
  {
    const Point& nj = m.corner_normal[j];
    // W = N_j (I - nu nu)/L (I - nu_j nu_j)/|s_j|
    std::array<double, 9> Pj{}, W{};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        Pj[3 * a + b] = ((a == b) - nj[a] * nj[b]) / m.corner_length[j];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
      {
        double v = 0;
        for (int c = 0; c < 3; ++c)
          v += ((a == c) - nu[a] * nu[c]) / L * Pj[3 * c + b];
        W[3 * a + b] = p.master_shape[j] * v;
      }
    for (std::size_t g : m.ring[j])
    {
      const Master& f = all[g];
      const Point a = sub(f.current.x[1], f.current.x[0]);
      const Point b = sub(f.current.x[2], f.current.x[0]);
      const std::array<double, 9> A_ = skew(a), B_ = skew(b);
      // dc/dx0 = [b] - [a], dc/dx1 = -[b], dc/dx2 = [a], times the orientation
      const std::array<double, 9> dc[3] = {
          {B_[0] - A_[0], B_[1] - A_[1], B_[2] - A_[2], B_[3] - A_[3], B_[4] - A_[4],
           B_[5] - A_[5], B_[6] - A_[6], B_[7] - A_[7], B_[8] - A_[8]},
          {-B_[0], -B_[1], -B_[2], -B_[3], -B_[4], -B_[5], -B_[6], -B_[7], -B_[8]},
          A_};
      for (int k = 0; k < 3; ++k)
      {
        std::array<double, 9>& D = dnu[f.current.node[k]];
        for (int d = 0; d < 3; ++d)
          fixed[f.current.node[k]][d] = f.fixed[3 * k + d];
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c)
          {
            double v = 0;
            for (int e = 0; e < 3; ++e)
              v += W[3 * r + e] * dc[k][3 * e + c];
            D[3 * r + c] += f.orientation * v;
          }
      }
    }
  }
  // rows: the force direction's factors (slave N_i, master -N_j) times eps w g
  const double fg = _settings.penalty * q.weight * p.gap;
  const int ns = static_cast<int>(rows.size()) / 3 - m.current.n;
  std::vector<double> factor;
  for (int i = 0; i < ns; ++i)
    factor.push_back(fg * q.N[i]);
  for (int j = 0; j < m.current.n; ++j)
    factor.push_back(-fg * p.master_shape[j]);
  std::vector<PetscInt> cols;
  std::vector<double> values(rows.size() * 3 * dnu.size());
  for (const auto& [node, D] : dnu)
    for (int c = 0; c < 3; ++c)
      cols.push_back(fixed[node][c] ? -1 : 3 * node + c);
  std::size_t n = 0;
  for (const auto& entry : dnu)
  {
    const std::array<double, 9>& D = entry.second;
    for (std::size_t r = 0; r < rows.size(); ++r)
      for (int c = 0; c < 3; ++c)
        values[r * cols.size() + 3 * n + c] = factor[r / 3] * D[3 * (r % 3) + c];
    ++n;
  }
  MatSetValues(A, rows.size(), rows.data(), cols.size(), cols.data(), values.data(), ADD_VALUES);
}

std::string ContactPair::diagnosis() const
{
  if (_changed == 0)
    return "";
  return _settings.name + ": the contact set was still changing (slave points in contact: "
         + std::to_string(_previous_active) + ", then " + std::to_string(_active)
         + " at the last evaluation)";
}

ContactPair::Measures ContactPair::measure()
{
  Measures m;
  // the pressure of a facet: the mean over its points in contact (a single
  // point's value carries the penalty's point-to-point scatter)
  std::vector<double> force(_slave.size(), 0), area(_slave.size(), 0);
  for_each_contact(
      [&](const QuadraturePoint& q, const Facet&, const Master&, const ContactPoint& p)
      {
        const double pressure = -_settings.penalty * p.gap;
        for (int k = 0; k < 3; ++k)
          m.force[k] += pressure * q.weight * p.normal[k];
        m.area += q.weight;
        force[q.facet] += pressure * q.weight;
        area[q.facet] += q.weight;
        m.max_penetration = std::max(m.max_penetration, -p.gap);
        ++m.points;
      });
  for (std::size_t e = 0; e < _slave.size(); ++e)
    if (area[e] > 0)
      m.max_pressure = std::max(m.max_pressure, force[e] / area[e]);
  MPI_Comm comm = _u->function_space()->mesh()->comm();
  MPI_Allreduce(MPI_IN_PLACE, m.force.data(), 3, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &m.area, 1, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &m.max_pressure, 1, MPI_DOUBLE, MPI_MAX, comm);
  MPI_Allreduce(MPI_IN_PLACE, &m.max_penetration, 1, MPI_DOUBLE, MPI_MAX, comm);
  MPI_Allreduce(MPI_IN_PLACE, &m.points, 1, MPI_INT64_T, MPI_SUM, comm);
  return m;
}

void ContactPair::add_nodal_sums(std::span<double> weight, std::span<double> gap,
                                 std::span<double> pressure)
{
  for_each_contact(
      [&](const QuadraturePoint& q, const Facet& s, const Master&, const ContactPoint& p)
      {
        for (int i = 0; i < s.reference.n; ++i)
        {
          const double w = q.weight * q.N[i];
          weight[s.block[i]] += w;
          gap[s.block[i]] += w * p.gap;
          pressure[s.block[i]] += w * _settings.penalty * std::max(-p.gap, 0.0);
        }
      },
      true);
}

ContactFields::ContactFields(const fem::FunctionSpace& V)
{
  auto [space, parent] = V.sub({0})->collapse();
  _space = std::make_shared<fem::FunctionSpace>(std::move(space));
  const int bs = V.dofmap()->index_map_bs();
  for (std::int32_t d : parent)
    _node.push_back(d / bs);
  const auto map = V.dofmap()->index_map;
  _blocks = map->size_local() + map->num_ghosts();
  _w = std::make_shared<la::Vector<double>>(_space->dofmap()->index_map,
                                            _space->dofmap()->index_map_bs());
  pressure = std::make_shared<fem::Function<double>>(_space);
  pressure->name = "contact_pressure";
  gap = std::make_shared<fem::Function<double>>(_space);
  gap->name = "contact_gap";
}

void ContactFields::update(const std::vector<std::shared_ptr<ContactPair>>& pairs)
{
  const std::size_t blocks = _blocks;
  // sums over the points of every pair (a node between two pairs gets their mean)
  std::vector<double> weight(blocks, 0), g(blocks, 0), p(blocks, 0);
  double reach = 0;
  for (const auto& pair : pairs)
  {
    pair->add_nodal_sums(weight, g, p);
    reach = std::max(reach, pair->settings().search_distance);
  }
  // node sums from each rank's facets; ghosts add onto their owners
  la::Vector<double>& W = *_w, &G = *gap->x(), &P = *pressure->x();
  std::span<double> w_ = W.mutable_array(), g_ = G.mutable_array(), p_ = P.mutable_array();
  for (std::size_t i = 0; i < _node.size(); ++i)
  {
    w_[i] = weight[_node[i]];
    g_[i] = g[_node[i]];
    p_[i] = p[_node[i]];
  }
  W.scatter_rev(std::plus<double>());
  G.scatter_rev(std::plus<double>());
  P.scatter_rev(std::plus<double>());
  for (std::size_t i = 0; i < _node.size(); ++i)
  {
    g_[i] = w_[i] > 0 ? g_[i] / w_[i] : reach;
    p_[i] = w_[i] > 0 ? p_[i] / w_[i] : 0;
  }
  G.scatter_fwd();
  P.scatter_fwd();
}

} // namespace muscle
