#include "rigid_body_modes.h"

#include "constraint.h"

#include <dolfinx/fem/DofMap.h>
#include <dolfinx/la/Vector.h>
#include <dolfinx/la/petsc.h>
#include <vector>

using namespace dolfinx;

namespace muscle
{

MatNullSpace rigid_body_modes(const fem::FunctionSpace& V,
                              const DisplacementConstraint* constraint)
{
  auto map = V.dofmap()->index_map;
  const int bs = V.dofmap()->index_map_bs();
  const std::int32_t n = map->size_local();
  std::vector<la::Vector<double>> basis(6, la::Vector<double>(map, bs));
  const std::vector<double> x = V.tabulate_dof_coordinates(false);
  for (std::int32_t i = 0; i < n; ++i)
  {
    const double* p = x.data() + 3 * i;
    for (int k = 0; k < 3; ++k)
      basis[k].mutable_array()[3 * i + k] = 1;
    // rotations about e3, e1, e2
    basis[3].mutable_array()[3 * i + 0] = -p[1];
    basis[3].mutable_array()[3 * i + 1] = p[0];
    basis[4].mutable_array()[3 * i + 1] = -p[2];
    basis[4].mutable_array()[3 * i + 2] = p[1];
    basis[5].mutable_array()[3 * i + 0] = p[2];
    basis[5].mutable_array()[3 * i + 2] = -p[0];
  }
  // PETSc-owned copies: the null space outlives `basis` (a wrapped array would
  // dangle, and GAMG would coarsen with whatever reuses that memory)
  std::vector<Vec> vecs;
  for (auto& b : basis)
  {
    Vec copy;
    if (constraint)
    {
      b.scatter_fwd();
      copy = constraint->create_reduced_vector();
      constraint->restrict_to(b, copy);
    }
    else
    {
      Vec wrap = la::petsc::create_vector_wrap(b);
      VecDuplicate(wrap, &copy);
      VecCopy(wrap, copy);
      VecDestroy(&wrap);
    }
    vecs.push_back(copy);
  }
  // PETSc asks for an orthonormal basis: Gram-Schmidt, twice for round-off
  for (std::size_t i = 0; i < vecs.size(); ++i)
    for (int pass = 0; pass < 2; ++pass)
    {
      for (std::size_t j = 0; j < i; ++j)
      {
        PetscScalar d;
        VecDot(vecs[i], vecs[j], &d);
        VecAXPY(vecs[i], -d, vecs[j]);
      }
      VecNormalize(vecs[i], nullptr);
    }
  MatNullSpace ns;
  MatNullSpaceCreate(map->comm(), PETSC_FALSE, 6, vecs.data(), &ns);
  for (Vec& v : vecs)
    VecDestroy(&v);
  return ns;
}

} // namespace muscle
