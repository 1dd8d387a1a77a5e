// The Newton system under a linear constraint u = T x (uniform-axial, tie):
// the reduced matrix T^T A T and the maps between reduced and full vectors.
#include "nonlinear_solver.h"

#include "constraint.h"

#include <dolfinx/la/petsc.h>

using namespace dolfinx;

namespace muscle
{

void NonlinearSolver::reduce(Mat J, bool first)
{
  PetscObjectState state;
  MatGetNonzeroState(_A, &state);
  // (MPIAIJ sums the nonzero state over the ranks at assembly, so every rank
  // takes the same, collective, branch)
  const bool changed = state != _reduced_state;
  if (first)
  {
    MatPtAP(_A, _constraint->T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, &_A_red);
    MatSetBlockSize(_A_red, _reduced_bs);
  }
  else if (changed)
  {
    // A gained nonzeros (contact): a new product of our own, copied into J (which
    // the KSP holds).  J's own product data describe the old pattern, so J is
    // never recomputed in place again: a numeric PtAP on a stale symbolic
    // product reads past its arrays (crashed on 2 ranks).  The later copies with
    // SAME_NONZERO_PATTERN rely on A's pattern only growing (contact adds
    // entries, nothing removes them), so J's pattern stays _ptap's.
    if (_ptap)
      MatDestroy(&_ptap);
    MatPtAP(_A, _constraint->T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, &_ptap);
    MatSetBlockSize(_ptap, _reduced_bs);
    MatSetOption(J, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
    MatCopy(_ptap, J, DIFFERENT_NONZERO_PATTERN);
  }
  else if (_ptap)
  {
    MatPtAP(_A, _constraint->T(), MAT_REUSE_MATRIX, PETSC_DEFAULT, &_ptap);
    MatCopy(_ptap, J, SAME_NONZERO_PATTERN);
  }
  else
    MatPtAP(_A, _constraint->T(), MAT_REUSE_MATRIX, PETSC_DEFAULT, &J);
  _reduced_state = state;
}

void NonlinearSolver::to_full(Vec du)
{
  if (_constraint)
    _constraint->prolong(du, _work);
  else
  {
    const PetscScalar* a;
    VecGetArrayRead(du, &a);
    PetscInt n;
    VecGetLocalSize(du, &n);
    std::copy(a, a + n, _work.mutable_array().begin());
    VecRestoreArrayRead(du, &a);
    _work.scatter_fwd();
  }
}

namespace
{
/// A PETSc vector over w's owned entries, sharing w's array (read only; destroy it after).
Vec owned_part(const la::Vector<double>& w)
{
  Vec v;
  const auto map = w.map();
  VecCreateMPIWithArray(map->comm(), 1, w.bs() * map->size_local(), PETSC_DETERMINE,
                        w.array().data(), &v);
  return v;
}
} // namespace

void NonlinearSolver::add_restricted(const la::Vector<double>& w, Vec x)
{
  PetscInt n;
  VecGetLocalSize(x, &n);
  if (_constraint)
  {
    Vec wv = owned_part(w);
    MatMultTransposeAdd(_constraint->T(), wv, x, x);
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

void NonlinearSolver::multiply_reduced(Vec y)
{
  if (!_full_tmp)
    MatCreateVecs(_A, nullptr, &_full_tmp);
  Vec wv = owned_part(_work);
  MatMult(_A, wv, _full_tmp);
  VecDestroy(&wv);
  MatMultTranspose(_constraint->T(), _full_tmp, y);
}

} // namespace muscle
