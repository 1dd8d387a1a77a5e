#pragma once

#include "common/petsc_handle.h"
#include "fem/constraints/constraint.h"

#include <dolfinx/fem/FunctionSpace.h>
#include <dolfinx/la/Vector.h>
#include <petscmat.h>
#include <vector>

namespace muscle
{

/// A set of degrees of freedom that all take the same, unknown value -- the
/// paper's multipoint constraint on the insertion of a freely contracting
/// muscle (every insertion node moves by the same axial displacement).
///
/// Enforced exactly by elimination: u = T x, where x holds every other degree
/// of freedom plus one global unknown U, T is a 0/1 prolongation matrix, and
/// the Newton system is T^T J T.  The equation for U is the sum of the
/// constrained rows: the total force on the constrained set is zero.
class UniformDisplacementConstraint : public DisplacementConstraint
{
public:
  /// `dofs`: local (owned or ghost) unrolled indices into V's vector.
  UniformDisplacementConstraint(const dolfinx::fem::FunctionSpace& V,
                                const std::vector<std::int32_t>& dofs);
  UniformDisplacementConstraint(const UniformDisplacementConstraint&) = delete;
  UniformDisplacementConstraint& operator=(const UniformDisplacementConstraint&) = delete;

  Mat T() const override { return _T; }

  /// x from u: unconstrained entries copied, U the constrained set's mean.
  void restrict_to(const dolfinx::la::Vector<double>& u, Vec x) const override;

  /// Current common value U of the constrained dofs, from u (collective).
  double value(const dolfinx::la::Vector<double>& u) const;

  /// Number of constrained dofs over all ranks.
  std::int64_t size() const { return _global_count; }

private:
  MPI_Comm _comm;
  MatHandle _T;
  std::int32_t _num_owned;
  std::vector<std::int32_t> _constrained_owned;
  PetscInt _reduced_local_size;
  std::int64_t _global_count;
};

} // namespace muscle
