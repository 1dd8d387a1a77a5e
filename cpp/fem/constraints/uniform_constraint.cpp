#include "fem/constraints/uniform_constraint.h"

#include <dolfinx/common/IndexMap.h>
#include <dolfinx/fem/DofMap.h>
#include <petscvec.h>

namespace muscle
{

UniformDisplacementConstraint::UniformDisplacementConstraint(
    const dolfinx::fem::FunctionSpace& V, const std::vector<std::int32_t>& dofs)
{
  auto map = V.dofmap()->index_map;
  const int bs = V.dofmap()->index_map_bs();
  _comm = map->comm();
  int rank = 0;
  MPI_Comm_rank(_comm, &rank);
  _num_owned = bs * map->size_local();

  std::vector<char> constrained(_num_owned, 0);
  for (std::int32_t d : dofs)
    if (d < _num_owned)
      constrained[d] = 1;

  // local reduced numbering: unconstrained owned dofs in order, then U on rank 0
  _reduced_index.assign(_num_owned, -1);
  PetscInt n = 0;
  for (std::int32_t i = 0; i < _num_owned; ++i)
  {
    if (constrained[i])
      _constrained_owned.push_back(i);
    else
      _reduced_index[i] = n++;
  }
  const PetscInt u_local = n;
  if (rank == 0)
    ++n;
  _reduced_local_size = n;

  PetscInt offset = 0;
  MPI_Exscan(&n, &offset, 1, MPIU_INT, MPI_SUM, _comm);
  if (rank == 0)
    offset = 0;
  PetscInt u_global = rank == 0 ? u_local : 0;
  MPI_Bcast(&u_global, 1, MPIU_INT, 0, _comm);

  const std::int64_t local_count = _constrained_owned.size();
  MPI_Allreduce(&local_count, &_global_count, 1, MPI_INT64_T, MPI_SUM, _comm);

  MatCreateAIJ(_comm, _num_owned, n, PETSC_DETERMINE, PETSC_DETERMINE, 1,
               nullptr, 1, nullptr, _T.out());
  MatSetOption(_T, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
  const PetscInt row0 = bs * map->local_range()[0];
  for (std::int32_t i = 0; i < _num_owned; ++i)
  {
    const PetscInt row = row0 + i;
    const PetscInt col = constrained[i] ? u_global : offset + _reduced_index[i];
    MatSetValue(_T, row, col, 1.0, INSERT_VALUES);
  }
  MatAssemblyBegin(_T, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_T, MAT_FINAL_ASSEMBLY);
}

double UniformDisplacementConstraint::value(const dolfinx::la::Vector<double>& u) const
{
  const std::span<const double> a = u.array();
  double local[2] = {0, 0};
  for (std::int32_t i : _constrained_owned)
  {
    local[0] += a[i];
    local[1] += 1;
  }
  double global[2];
  MPI_Allreduce(local, global, 2, MPI_DOUBLE, MPI_SUM, _comm);
  return global[1] > 0 ? global[0] / global[1] : 0.0;
}

void UniformDisplacementConstraint::restrict_to(const dolfinx::la::Vector<double>& u,
                                                Vec x) const
{
  const double U = value(u);
  PetscScalar* xr;
  VecGetArray(x, &xr);
  copy_free_dofs(u, xr);
  int rank;
  MPI_Comm_rank(_comm, &rank);
  if (rank == 0)
    xr[_reduced_local_size - 1] = U;
  VecRestoreArray(x, &xr);
}

} // namespace muscle
