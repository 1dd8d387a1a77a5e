#pragma once

#include "common/petsc_handle.h"
#include "fem/constraints/constraint.h"

#include <array>
#include <dolfinx/fem/FunctionSpace.h>
#include <string>
#include <vector>

namespace muscle
{

/// Surfaces of separately meshed bodies glued together by dual mortar
/// (Wohlmuth): u_s = sum_m (int psi_s N_m dA / int psi_s dA) u_m, psi_s the dual
/// basis of the slave surface, the integrals exact over the clipped overlaps of
/// slave and master facets (surface_geometry.h).  Node-to-surface interpolation
/// would fail the patch test on non-nested meshes (the consistent nodal forces
/// do not transfer); the dual mortar reproduces linear fields and transfers
/// uniform tractions exactly.  The slave nodes' unknowns are eliminated (u = T x,
/// the Newton system T^T J T).  Degree-1 elements.
class TieConstraint : public DisplacementConstraint
{
public:
  struct Pair
  {
    std::string name;                  ///< for messages: "tie[0]"
    std::vector<std::int32_t> slave;   ///< local facets of the slave surface
    std::vector<std::int32_t> master;  ///< local facets of the master surface
    double tolerance;                  ///< largest slave-node distance from the master [mm]
  };

  /// `fixed`: local unrolled dofs with a Dirichlet condition (sorted); such a
  /// component of a slave node keeps its condition instead of following the
  /// master (a symmetry plane through the interface).  InputError if a slave node
  /// lies farther than its pair's tolerance from the master surface, if a node is
  /// the slave of two pairs, or if a master node is a slave.  Collective.
  TieConstraint(const dolfinx::fem::FunctionSpace& V, const std::vector<Pair>& pairs,
                const std::vector<std::int32_t>& fixed);
  TieConstraint(const TieConstraint&) = delete;
  TieConstraint& operator=(const TieConstraint&) = delete;

  Mat T() const override { return _T; }
  void restrict_to(const dolfinx::la::Vector<double>& u, Vec x) const override;
  /// True unless a slave node has a Dirichlet condition on one or two
  /// components (they stay unknowns, the others follow the master).
  bool keeps_whole_nodes() const override { return _whole_nodes; }

  /// Slave nodes over all ranks, and the largest slave-to-master distance found.
  std::int64_t slave_nodes() const { return _slave_nodes; }
  double largest_gap() const { return _largest_gap; }

private:
  MatHandle _T;
  std::int32_t _num_owned = 0;               ///< unrolled
  std::int64_t _slave_nodes = 0;
  double _largest_gap = 0;
  bool _whole_nodes = true;
};

} // namespace muscle
