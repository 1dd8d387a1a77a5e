#include "fem/constraints/constraint.h"

#include <algorithm>
#include <petscvec.h>

namespace muscle
{

Vec DisplacementConstraint::create_reduced_vector() const
{
  Vec x;
  MatCreateVecs(T(), &x, nullptr);
  return x;
}

void DisplacementConstraint::prolong(Vec x, dolfinx::la::Vector<double>& u) const
{
  PetscInt rows, columns;
  MatGetLocalSize(T(), &rows, &columns);
  MPI_Comm comm;
  PetscObjectGetComm(reinterpret_cast<PetscObject>(T()), &comm);
  Vec full;
  VecCreateMPIWithArray(comm, 1, rows, PETSC_DETERMINE, u.mutable_array().data(), &full);
  MatMult(T(), x, full);
  VecDestroy(&full);
  u.scatter_fwd();
}

void DisplacementConstraint::copy_free_dofs(const dolfinx::la::Vector<double>& u,
                                            PetscScalar* x) const
{
  const std::span<const double> a = u.array();
  for (std::size_t i = 0; i < _reduced_index.size(); ++i)
    if (_reduced_index[i] >= 0)
      x[_reduced_index[i]] = a[i];
}

std::vector<std::int64_t> DisplacementConstraint::reduced_numbers() const
{
  PetscInt start, end;
  MatGetOwnershipRangeColumn(T(), &start, &end);
  std::vector<std::int64_t> numbers(_reduced_index.size(), -1);
  for (std::size_t i = 0; i < _reduced_index.size(); ++i)
    if (_reduced_index[i] >= 0)
      numbers[i] = start + _reduced_index[i];
  return numbers;
}

Mat DisplacementConstraint::restriction() const
{
  Mat TtT, R;
  MatTransposeMatMult(T(), T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, &TtT);
  Vec d;
  MatCreateVecs(TtT, &d, nullptr);
  MatGetDiagonal(TtT, d);
  VecReciprocal(d);
  MatTranspose(T(), MAT_INITIAL_MATRIX, &R);
  MatDiagonalScale(R, d, nullptr);
  VecDestroy(&d);
  MatDestroy(&TtT);
  return R;
}

std::int64_t DisplacementConstraint::reduced_size() const
{
  PetscInt rows, columns;
  MatGetSize(T(), &rows, &columns);
  return columns;
}

void to_full(const DisplacementConstraint* constraint, Vec du, dolfinx::la::Vector<double>& w)
{
  if (constraint)
    constraint->prolong(du, w);
  else
  {
    const PetscScalar* a;
    VecGetArrayRead(du, &a);
    PetscInt n;
    VecGetLocalSize(du, &n);
    std::copy(a, a + n, w.mutable_array().begin());
    VecRestoreArrayRead(du, &a);
    w.scatter_fwd();
  }
}

Vec owned_part(const dolfinx::la::Vector<double>& w)
{
  Vec v;
  const auto map = w.map();
  VecCreateMPIWithArray(map->comm(), 1, w.bs() * map->size_local(), PETSC_DETERMINE,
                        w.array().data(), &v);
  return v;
}

void add_restricted(const DisplacementConstraint* constraint, const dolfinx::la::Vector<double>& w,
                    Vec x)
{
  PetscInt n;
  VecGetLocalSize(x, &n);
  if (constraint)
  {
    Vec wv = owned_part(w);
    MatMultTransposeAdd(constraint->T(), wv, x, x);
    VecDestroy(&wv);
  }
  else
  {
    PetscScalar* a;
    VecGetArray(x, &a);
    for (PetscInt i = 0; i < n; ++i)
      a[i] += w.array()[i];
    VecRestoreArray(x, &a);
  }
}

} // namespace muscle
