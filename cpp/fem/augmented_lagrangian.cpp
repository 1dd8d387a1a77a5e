#include "augmented_lagrangian.h"

#include <algorithm>
#include <stdexcept>

namespace muscle
{

AugmentedLagrangian::~AugmentedLagrangian()
{
  VecDestroy(&_w_inv);
  VecDestroy(&_work);
  MatDestroy(&_A_gamma);
}

void AugmentedLagrangian::begin(Mat A)
{
  PetscObjectState pattern;
  MatGetNonzeroState(A, &pattern);
  if (!_A_gamma or pattern != _pattern)
  {
    // a new object rather than MatCopy(DIFFERENT_NONZERO_PATTERN), which
    // replaces the matrix's header and loses what is attached to it
    MatNullSpace near_null_space = nullptr;
    if (_A_gamma)
    {
      MatGetNearNullSpace(_A_gamma, &near_null_space);
      PetscObjectReference(reinterpret_cast<PetscObject>(near_null_space));
      MatDestroy(&_A_gamma);
    }
    MatDuplicate(A, MAT_COPY_VALUES, &_A_gamma);
    if (near_null_space)
    {
      MatSetNearNullSpace(_A_gamma, near_null_space);
      MatNullSpaceDestroy(&near_null_space);
    }
    _pattern = pattern;
  }
  else
    MatCopy(A, _A_gamma, SAME_NONZERO_PATTERN);
  _cell_w.clear();
  _cell_q.clear();
  _next = 0;
  _order_broken = false;
  _insert_failed = false;
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
  if (_order_broken or _next + n > _cell_q.size()
      or !std::equal(q_dofs.begin(), q_dofs.end(), _cell_q.begin() + _next))
  {
    _order_broken = true;
    return;
  }
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
  if (MatSetValuesBlockedLocal(_A_gamma, _u_dofs.size(), _u_dofs.data(), _u_dofs.size(),
                               _u_dofs.data(), _K.data(), ADD_VALUES))
    _insert_failed = true;
}

void AugmentedLagrangian::end(Mat A_qq)
{
  MatAssemblyBegin(_A_gamma, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_A_gamma, MAT_FINAL_ASSEMBLY);
  // one rank's defect, every rank's throw: a throw on one rank alone would leave
  // the others waiting in the next collective call
  int broken[2] = {_order_broken or _next != _cell_q.size(), _insert_failed};
  MPI_Allreduce(MPI_IN_PLACE, broken, 2, MPI_INT, MPI_MAX,
                PetscObjectComm(reinterpret_cast<PetscObject>(_A_gamma)));
  if (broken[0])
    throw std::logic_error("AugmentedLagrangian: the cells of A_qu's assembly do not follow "
                           "A_qq's");
  if (broken[1])
    throw std::runtime_error("AugmentedLagrangian: PETSc refused a cell's entries of "
                             "A_gamma (MatSetValuesBlockedLocal failed)");
  if (!_w_inv)
    MatCreateVecs(A_qq, &_w_inv, &_work);
  PetscInt start, stop;
  MatGetOwnershipRange(A_qq, &start, &stop);
  for (PetscInt row = start; row < stop; row += 2) // theta rows: even
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
}

PetscErrorCode AugmentedLagrangian::add_constraint_rows(Vec rhs_u, Vec r_q, Vec z_q,
                                                        Mat A_qu, Mat A_qq)
{
  PetscFunctionBeginUser;
  PetscCall(MatMult(A_qq, z_q, _work));
  PetscCall(VecAYPX(_work, -1.0, r_q));
  PetscCall(VecPointwiseMult(_work, _work, _w_inv));
  PetscCall(VecScale(_work, _gamma));
  PetscCall(MatMultTransposeAdd(A_qu, _work, rhs_u, rhs_u));
  PetscFunctionReturn(0);
}

} // namespace muscle
