#pragma once

#include <array>
#include <cstdint>
#include <tuple>
#include <vector>

namespace muscle
{

using Point = std::array<double, 3>;

/// A facet of a surface of degree-1 elements: its nodes (reference or current
/// coordinates) and their global node numbers; quadrilaterals in tensor order
/// (node 3 opposite node 0), triangles in any order.
struct SurfaceFacet
{
  int n = 0;
  std::array<Point, 4> x;
  std::array<std::int64_t, 4> node;
};

inline double dot(const Point& a, const Point& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Point sub(const Point& a, const Point& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline Point cross(const Point& a, const Point& b)
{
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

/// The mean of a facet's nodes.
Point facet_centre(const SurfaceFacet& f);
/// a1 x a2 at node 0 (tensor order), or the triangle's edge cross product: the
/// facet's normal up to length and sign.
Point facet_normal(const SurfaceFacet& f);

/// Puts a quadrilateral's nodes in tensor order (the node farthest from node 0
/// last); triangles are left as they are.
void tensor_order(SurfaceFacet& f);

/// The point of the facet closest to p: (distance, the facet's shape functions
/// there).  Bilinear quadrilaterals by Gauss-Newton on [0, 1]^2, triangles exactly.
std::pair<double, std::array<double, 4>> closest_point(const SurfaceFacet& f, const Point& p);

/// Dual-mortar coupling of a slave surface to a master surface lying on it
/// (Wohlmuth's dual basis psi_i, biorthogonal to the slave shape functions):
/// for each slave facet, the integrals of psi_i N_m over its overlap with each
/// master facet, the overlap found by clipping the master facet projected onto
/// the slave facet's plane (exact for planar parallelogram facets).  Returns
/// (slave node, master node, integral) triples, one per pair and facet.
std::vector<std::tuple<std::int64_t, std::int64_t, double>>
dual_mortar(const std::vector<SurfaceFacet>& slave, const std::vector<SurfaceFacet>& master,
            double distance);

} // namespace muscle
