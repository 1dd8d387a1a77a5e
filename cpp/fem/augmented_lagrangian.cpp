#include "augmented_lagrangian.h"

#include <algorithm>
#include <stdexcept>

namespace muscle
{

AugmentedLagrangian::~AugmentedLagrangian()
{
  VecDestroy(&_w_inv);
  VecDestroy(&_work);
  MatDestroy(&_cell_sum);
  MatDestroy(&_A_gamma);
}

void AugmentedLagrangian::begin(Mat A, Mat A_qq)
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

  PetscObjectState pattern;
  MatGetNonzeroState(A, &pattern);
  if (pattern != _pattern)
  {
    MatDestroy(&_cell_sum);
    MatDuplicate(A, MAT_DO_NOT_COPY_VALUES, &_cell_sum);
  }
  MatZeroEntries(_cell_sum);
  _cell_w.clear();
  _cell_q.clear();
  _next = 0;
}

void AugmentedLagrangian::add_cell_mass(std::span<const std::int32_t> q_dofs,
                                        std::span<const double> A_qq_e)
{
  const std::size_t n = q_dofs.size(), cols = 2 * n;
  for (std::size_t i = 0; i < n; ++i)
  {
    double w = 0;
    for (std::size_t j = 0; j < n; ++j)
      w -= A_qq_e[2 * i * cols + 2 * j + 1]; // (theta_i, p_j): -M_ij
    _cell_w.push_back(w);
  }
  _cell_q.insert(_cell_q.end(), q_dofs.begin(), q_dofs.end());
}

void AugmentedLagrangian::add_cell_coupling(std::span<const std::int32_t> q_dofs,
                                            std::span<const std::int32_t> u_dofs,
                                            std::span<const double> A_qu_e)
{
  const std::size_t n = q_dofs.size(), m = 3 * u_dofs.size();
  if (_next + n > _cell_q.size()
      or !std::equal(q_dofs.begin(), q_dofs.end(), _cell_q.begin() + _next))
    throw std::logic_error("AugmentedLagrangian: A_qu's cells do not follow A_qq's");
  _K.assign(m * m, 0.0);
  for (std::size_t i = 0; i < n; ++i)
  {
    const double* b = &A_qu_e[(2 * i + 1) * m]; // p_i's row (Dirichlet columns zero)
    const double s = _gamma / _cell_w[_next + i];
    for (std::size_t k = 0; k < m; ++k)
      for (std::size_t l = 0; l < m; ++l)
        _K[k * m + l] += s * b[k] * b[l];
  }
  _next += n;
  _u_dofs.assign(u_dofs.begin(), u_dofs.end());
  MatSetValuesBlockedLocal(_cell_sum, _u_dofs.size(), _u_dofs.data(), _u_dofs.size(),
                           _u_dofs.data(), _K.data(), ADD_VALUES);
}

Mat AugmentedLagrangian::end(Mat A)
{
  MatAssemblyBegin(_cell_sum, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_cell_sum, MAT_FINAL_ASSEMBLY);
  PetscObjectState pattern;
  MatGetNonzeroState(A, &pattern);
  if (!_A_gamma)
    MatDuplicate(A, MAT_COPY_VALUES, &_A_gamma);
  else if (pattern != _pattern)
  {
    MatSetOption(_A_gamma, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
    MatCopy(A, _A_gamma, DIFFERENT_NONZERO_PATTERN);
  }
  else
    MatCopy(A, _A_gamma, SAME_NONZERO_PATTERN);
  _pattern = pattern;
  MatAXPY(_A_gamma, 1.0, _cell_sum, SUBSET_NONZERO_PATTERN);
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
