#include "fem/linear/augmented_lagrangian.h"

#include <algorithm>
#include <stdexcept>

namespace muscle
{

void AugmentedLagrangian::begin(Mat A)
{
  _A_gamma = A;
  if (!_B)
    release_csr(); // a first assembly that threw before end() left its rows
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
  _u_dofs.assign(u_dofs.begin(), u_dofs.end());
  // B_b's columns: u's local dofs, unblocked, through A's local-to-global map
  _columns.resize(m);
  for (std::size_t k = 0; k < u_dofs.size(); ++k)
    for (int c = 0; c < 3; ++c)
      _columns[3 * k + c] = 3 * u_dofs[k] + c;
  ISLocalToGlobalMapping l2g;
  MatGetLocalToGlobalMapping(_A_gamma, nullptr, &l2g);
  ISLocalToGlobalMappingApply(l2g, m, _columns.data(), _columns.data());
  if (!_B and _B_ptr.empty())
  {
    // every cell has as many rows and columns: no growth past B_b's size
    _B_ptr.reserve(_cell_w.size() + 1);
    _B_cols.reserve(_cell_w.size() * m);
    _B_values.reserve(_cell_w.size() * m);
    _B_ptr.push_back(0);
  }
  _K.assign(m * m, 0.0);
  for (std::size_t i = 0; i < n; ++i)
  {
    const double* b = &A_qu_e[(2 * i + 1) * m]; // p_i's row (Dirichlet columns zero)
    const double s = _gamma / _cell_w[_next + i];
    for (std::size_t k = 0; k < m; ++k)
      for (std::size_t l = 0; l < m; ++l)
        _K[k * m + l] += s * b[k] * b[l];
    if (_B)
    {
      const PetscInt row = _B_start + _next + i;
      if (MatSetValues(_B, 1, &row, m, _columns.data(), b, INSERT_VALUES))
        _insert_failed = true;
    }
    else
    {
      _B_cols.insert(_B_cols.end(), _columns.begin(), _columns.end());
      _B_values.insert(_B_values.end(), b, b + m);
      _B_ptr.push_back(_B_cols.size());
    }
  }
  _next += n;
  if (MatSetValuesBlockedLocal(_A_gamma, _u_dofs.size(), _u_dofs.data(), _u_dofs.size(),
                               _u_dofs.data(), _K.data(), ADD_VALUES))
    _insert_failed = true;
}

void AugmentedLagrangian::end(Mat A_qq)
{
  MatAssemblyBegin(_A_gamma, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_A_gamma, MAT_FINAL_ASSEMBLY);
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(_A_gamma));
  const PetscInt rows = _cell_w.size();
  PetscInt B_rows = rows;
  if (_B)
    MatGetLocalSize(_B, &B_rows, nullptr);
  // one rank's defect, every rank's throw: a throw on one rank alone would leave
  // the others waiting in the next collective call
  int broken[2] = {_order_broken or _next != _cell_q.size() or B_rows != rows, _insert_failed};
  MPI_Allreduce(MPI_IN_PLACE, broken, 2, MPI_INT, MPI_MAX, comm);
  if (broken[0])
    throw std::logic_error("AugmentedLagrangian: the cells of A_qu's assembly do not follow "
                           "A_qq's, or their number changed");
  if (broken[1])
    throw std::runtime_error("AugmentedLagrangian: PETSc refused a cell's entries of "
                             "A_gamma or B_b (MatSetValues(Blocked)Local failed)");
  if (!_B)
  {
    PetscInt u_owned;
    MatGetLocalSize(_A_gamma, nullptr, &u_owned);
    if (_B_ptr.empty())
      _B_ptr.push_back(0); // a rank without cells
    const PetscErrorCode error
        = MatCreateMPIAIJWithArrays(comm, rows, u_owned, PETSC_DETERMINE, PETSC_DETERMINE,
                                    _B_ptr.data(), _B_cols.data(), _B_values.data(), _B.out());
    release_csr(); // PETSc copied them
    if (error)
      throw std::runtime_error("AugmentedLagrangian: PETSc could not make B_b");
    MatGetOwnershipRange(_B, &_B_start, nullptr);
    MatCreateVecs(_B, nullptr, _minus_d.out());
    VecDuplicate(_minus_d, _Bx.out());
  }
  else
  {
    MatAssemblyBegin(_B, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(_B, MAT_FINAL_ASSEMBLY);
  }
  PetscScalar* d;
  VecGetArray(_minus_d, &d);
  for (PetscInt r = 0; r < rows; ++r)
    d[r] = -_gamma / _cell_w[r];
  VecRestoreArray(_minus_d, &d);

  if (!_w_inv)
    MatCreateVecs(A_qq, _w_inv.out(), _work.out());
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

void AugmentedLagrangian::release_csr()
{
  // (assigning {} would keep the capacity)
  std::vector<PetscInt>().swap(_B_ptr);
  std::vector<PetscInt>().swap(_B_cols);
  std::vector<double>().swap(_B_values);
}

Mat AugmentedLagrangian::jacobian_block(Mat base, Mat T)
{
  if (!_B)
    throw std::logic_error("AugmentedLagrangian::jacobian_block before the first end()");
  _base = base;
  _T = T;
  if (!_shell)
  {
    PetscInt local, global;
    MatGetLocalSize(base, &local, nullptr);
    MatGetSize(base, &global, nullptr);
    MatCreateShell(PetscObjectComm(reinterpret_cast<PetscObject>(base)), local, local, global,
                   global, this, _shell.out());
    MatShellSetOperation(_shell, MATOP_MULT, reinterpret_cast<void (*)(void)>(multiply));
  }
  if (T and !_full_x)
  {
    MatCreateVecs(_B, _full_x.out(), nullptr);
    VecDuplicate(_full_x, _full_y.out());
  }
  return _shell;
}

PetscErrorCode AugmentedLagrangian::multiply(Mat shell, Vec x, Vec y)
{
  PetscFunctionBeginUser;
  AugmentedLagrangian* self;
  PetscCall(MatShellGetContext(shell, &self));
  PetscCall(MatMult(self->_base, x, y));
  Vec full = x;
  if (self->_T)
  {
    PetscCall(MatMult(self->_T, x, self->_full_x));
    full = self->_full_x;
  }
  PetscCall(MatMult(self->_B, full, self->_Bx));
  PetscCall(VecPointwiseMult(self->_Bx, self->_Bx, self->_minus_d));
  if (self->_T)
  {
    PetscCall(MatMultTranspose(self->_B, self->_Bx, self->_full_y));
    PetscCall(MatMultTransposeAdd(self->_T, self->_full_y, y, y));
  }
  else
    PetscCall(MatMultTransposeAdd(self->_B, self->_Bx, y, y));
  PetscFunctionReturn(0);
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
