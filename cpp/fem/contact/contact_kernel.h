#pragma once

#include "fem/geometry/surface_geometry.h"

#include <vector>

namespace muscle
{

/// One slave quadrature point against one master facet, frictionless penalty
/// contact (Gauss point to segment).  With x_m(xi) the closest point of the
/// master facet to the slave point x_s and n the master's outward normal there,
/// the gap is g = (x_s - x_m) . n, the energy eps/2 <-g>^2 w, the residual
/// eps w <g>_- dg/du and the tangent its exact derivative
///   eps w [ H(-g) dg/du (x) dg/du + <g>_- d2g/du2 ],
/// d2g/du2 with the closest point's motion and the normal's rotation
/// (Wriggers, Computational Contact Mechanics, 2006, section 4.3).
/// Unknowns: the slave facet's nodes, then the master facet's, 3 components each.
struct ContactPoint
{
  double gap = 0;                  ///< mm, < 0: penetration
  Point normal{};                  ///< master's outward unit normal at the closest point
  double distance = 0;             ///< |x_s - x_m|
  std::array<double, 4> master_shape{}; ///< N_m at the closest point
  std::vector<double> residual;    ///< 3 (ns + nm)
  std::vector<double> tangent;     ///< (3 (ns + nm))^2, row-major
};

/// `slave`: the slave facet's nodes (current), `Ns` their shape functions at the
/// point; `master`: the master facet (current), `orientation` +1 or -1 turning
/// the facet's a1 x a2 outward; `eps` the penalty (kPa/mm), `weight` the
/// point's reference area (mm^2).  Residual and tangent are filled when g <= 0.
///
/// `corner_normals` (optional): outward unit normals at the master facet's nodes,
/// averaged over the neighbouring facets.  The force then acts along their
/// interpolation nu(xi) (normalised) instead of the facet normal, while the gap
/// stays the facet's.  On a faceted curved surface the facet normal jumps from
/// facet to facet, and a sliding point comes to rest on a ridge where no
/// equilibrium exists (Newton cycles); nu is continuous across facets that
/// average the same neighbours at their shared nodes (ContactPair: all within
/// 45 degrees).  The residual is then no energy gradient; the tangent here is
/// its derivative with the corner normals held fixed, and
/// ContactPair::add_normal_motion adds their motion with the neighbouring nodes.
/// The normal returned is nu also for a point not in contact.
ContactPoint contact_point(const SurfaceFacet& slave, const std::array<double, 4>& Ns,
                           const SurfaceFacet& master, int orientation, double eps,
                           double weight, const std::array<Point, 4>* corner_normals = nullptr);

/// Shape-function derivatives of a facet at its point with shape functions N
/// (bilinear quadrilaterals: (xi, eta) recovered from N; triangles constant).
void facet_derivatives(const SurfaceFacet& f, const std::array<double, 4>& N,
                       std::array<double, 4>& d1, std::array<double, 4>& d2,
                       std::array<double, 4>& d12);

} // namespace muscle
