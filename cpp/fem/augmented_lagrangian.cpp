#include "augmented_lagrangian.h"

namespace muscle
{

AugmentedLagrangian::~AugmentedLagrangian()
{
  VecDestroy(&_w_inv);
  VecDestroy(&_work);
  MatDestroy(&_scaled_coupling);
  MatDestroy(&_grad_div);
  MatDestroy(&_A_gamma);
}

Mat AugmentedLagrangian::update(Mat A, Mat A_qu, Mat A_qq)
{
  if (!_w_inv)
    MatCreateVecs(A_qq, &_w_inv, &_work);
  PetscInt start, end;
  MatGetOwnershipRange(A_qq, &start, &end);
  for (PetscInt row = start; row < end; row += 2) // theta rows: even
  {
    PetscInt n;
    const PetscInt* cols;
    const PetscScalar* values;
    MatGetRow(A_qq, row, &n, &cols, &values);
    double lumped = 0;
    for (PetscInt k = 0; k < n; ++k)
      if (cols[k] % 2 == 1)
        lumped -= values[k];
    MatRestoreRow(A_qq, row, &n, &cols, &values);
    VecSetValue(_w_inv, row, 0.0, INSERT_VALUES);
    VecSetValue(_w_inv, row + 1, 1.0 / lumped, INSERT_VALUES);
  }
  VecAssemblyBegin(_w_inv);
  VecAssemblyEnd(_w_inv);

  // A_qu's theta rows drop out through the zeros of W^-1, so B^T W^-1 B is
  // A_qu^T diag(w_inv) A_qu
  if (!_scaled_coupling)
    MatDuplicate(A_qu, MAT_COPY_VALUES, &_scaled_coupling);
  else
    MatCopy(A_qu, _scaled_coupling, SAME_NONZERO_PATTERN);
  MatDiagonalScale(_scaled_coupling, _w_inv, nullptr);
  MatTransposeMatMult(A_qu, _scaled_coupling,
                      _grad_div ? MAT_REUSE_MATRIX : MAT_INITIAL_MATRIX, PETSC_DEFAULT,
                      &_grad_div);

  PetscObjectState pattern;
  MatGetNonzeroState(A, &pattern);
  if (!_A_gamma or pattern != _pattern)
  {
    // a new pattern (contact) goes into the same matrix, so that its solvers,
    // near-null space and Galerkin products see it change
    Mat fresh;
    MatDuplicate(A, MAT_COPY_VALUES, &fresh);
    MatAXPY(fresh, _gamma, _grad_div, DIFFERENT_NONZERO_PATTERN);
    if (!_A_gamma)
      _A_gamma = fresh;
    else
    {
      MatSetOption(_A_gamma, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
      MatCopy(fresh, _A_gamma, DIFFERENT_NONZERO_PATTERN);
      MatDestroy(&fresh);
    }
    _pattern = pattern;
  }
  else
  {
    MatZeroEntries(_A_gamma);
    MatAXPY(_A_gamma, 1.0, A, SUBSET_NONZERO_PATTERN);
    MatAXPY(_A_gamma, _gamma, _grad_div, SUBSET_NONZERO_PATTERN);
  }
  return _A_gamma;
}

void AugmentedLagrangian::add_constraint_rows(Vec rhs_u, Vec r_q, Vec z_q, Mat A_qu,
                                              Mat A_qq)
{
  MatMult(A_qq, z_q, _work);
  VecAYPX(_work, -1.0, r_q);
  VecPointwiseMult(_work, _work, _w_inv);
  VecScale(_work, _gamma);
  MatMultTransposeAdd(A_qu, _work, rhs_u, rhs_u);
}

} // namespace muscle
