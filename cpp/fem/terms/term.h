#pragma once

#include <petscmat.h>
#include <petscvec.h>
#include <string>

namespace muscle
{

/// A contribution to the residual and tangent that is no form (contact,
/// inertia): added at the current displacement into full-layout PETSc objects
/// by global index (rows and columns of fixed dofs left out: negative indices).
class NonlinearTerm
{
public:
  virtual ~NonlinearTerm() = default;
  virtual void add_residual(Vec F) = 0;
  virtual void add_jacobian(Mat A) = 0;
  /// What to say when Newton fails ("" if nothing).
  virtual std::string diagnosis() const { return ""; }
};

} // namespace muscle
