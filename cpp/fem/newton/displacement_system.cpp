#include "fem/newton/displacement_system.h"

#include "fem/constraints/constraint.h"

#include <cmath>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/la/petsc.h>
#include <limits>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// The infinity norm (the scale of the round-off floor), or NaN when any entry
/// is not finite: PETSc's infinity norm skips a NaN row sum, the Frobenius
/// norm propagates it.
double finite_norm(Mat A)
{
  PetscReal inf, frobenius;
  MatNorm(A, NORM_INFINITY, &inf);
  MatNorm(A, NORM_FROBENIUS, &frobenius);
  return std::isfinite(frobenius) ? inf : std::numeric_limits<double>::quiet_NaN();
}
} // namespace

DisplacementSystem::DisplacementSystem(std::vector<MuscleProblem*> parts, DirichletBCs bcs,
                                       std::shared_ptr<const DisplacementConstraint> constraint)
    : _parts(std::move(parts)), _bcs(std::move(bcs)), _constraint(std::move(constraint)),
      _b(_parts.at(0)->V()->dofmap()->index_map, _parts.at(0)->V()->dofmap()->index_map_bs())
{
  MuscleProblem& first = problem();
  auto V = first.V();
  auto map = V->dofmap()->index_map;
  const int bs = V->dofmap()->index_map_bs();
  if (_parts.size() == 1)
    *_A.out() = fem::petsc::create_matrix(*first.jacobian(), "aij");
  else
  {
    // every cell couples its dofs, whichever part it belongs to
    const auto& dofmap = *V->dofmap();
    la::SparsityPattern pattern = fem::create_sparsity_pattern(
        first.mesh()->topology(), {std::cref(dofmap), std::cref(dofmap)},
        {fem::IntegralType::cell});
    pattern.assemble();
    *_A.out() = la::petsc::create_matrix(map->comm(), pattern, "aij");
  }
  *_b_petsc.out() = la::petsc::create_vector_wrap(_b);
  *_u_petsc.out() = la::petsc::create_vector_wrap(*first.u()->x());
  VecCreateMPIWithArray(map->comm(), 1, bs * map->size_local(), PETSC_DETERMINE,
                        _b.mutable_array().data(), _F_full.out());
}

MPI_Comm DisplacementSystem::comm() const { return problem().mesh()->comm(); }

void DisplacementSystem::add_forms(
    std::vector<std::shared_ptr<const fem::Form<double>>> residuals,
    std::vector<std::shared_ptr<const fem::Form<double>>> jacobians)
{
  _extra_residuals.insert(_extra_residuals.end(), residuals.begin(), residuals.end());
  _extra_jacobians.insert(_extra_jacobians.end(), jacobians.begin(), jacobians.end());
}

void DisplacementSystem::add_term(std::shared_ptr<NonlinearTerm> term)
{
  if (!_term_F)
  {
    VecDuplicate(_b_petsc, _term_F.out());
    VecSetOption(_term_F, VEC_IGNORE_NEGATIVE_INDICES, PETSC_TRUE); // fixed dofs
    MatSetOption(_A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
    if (_A_red)
      MatSetOption(_A_red, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
  }
  _terms.push_back(std::move(term));
}

void DisplacementSystem::add_term_residuals(std::span<double> b) const
{
  if (_terms.empty())
    return;
  VecZeroEntries(_term_F);
  for (const auto& t : _terms)
    t->add_residual(_term_F);
  VecAssemblyBegin(_term_F);
  VecAssemblyEnd(_term_F);
  const PetscScalar* f;
  PetscInt n;
  VecGetLocalSize(_term_F, &n);
  VecGetArrayRead(_term_F, &f);
  for (PetscInt i = 0; i < n; ++i)
    b[i] += f[i];
  VecRestoreArrayRead(_term_F, &f);
}

void DisplacementSystem::residual()
{
  std::span<double> b = _b.mutable_array();
  std::fill(b.begin(), b.end(), 0.0);
  std::span<const double> u = problem().u()->x()->array();
  for (MuscleProblem* part : _parts)
  {
    fem::assemble_vector<double>(b, *part->residual());
    fem::apply_lifting<double>(b, {part->jacobian()}, {_bcs}, {u}, -1.0);
  }
  for (const auto& r : _extra_residuals)
    fem::assemble_vector<double>(b, *r);
  for (const auto& J : _extra_jacobians)
    fem::apply_lifting<double>(b, {J}, {_bcs}, {u}, -1.0);
  _b.scatter_rev(std::plus<double>());
  add_term_residuals(b);
  fem::set_bc<double>(b, _bcs, u, -1.0);
}

void DisplacementSystem::unlifted_residual(const std::function<void(std::span<double>)>& add_parts)
{
  std::span<double> b = _b.mutable_array();
  std::fill(b.begin(), b.end(), 0.0);
  add_parts(b);
  for (const auto& r : _extra_residuals)
    fem::assemble_vector<double>(b, *r);
  std::span<const double> u = problem().u()->x()->array();
  _b.scatter_rev(std::plus<double>());
  add_term_residuals(b);
  fem::set_bc<double>(b, _bcs, u, -1.0);
}

void DisplacementSystem::restrict_residual(Vec F) const
{
  if (_constraint)
    MatMultTranspose(_constraint->T(), _F_full, F);
  else
    VecCopy(_b_petsc, F);
}

VecHandle DisplacementSystem::create_unknowns() const
{
  VecHandle x;
  if (_constraint)
    *x.out() = _constraint->create_reduced_vector();
  else // SNES owns its iterate: the line search tries its states in u
    VecDuplicate(_u_petsc, x.out());
  return x;
}

void DisplacementSystem::get_unknowns(Vec x) const
{
  if (_constraint)
    _constraint->restrict_to(*problem().u()->x(), x);
  else
    VecCopy(_u_petsc, x);
}

void DisplacementSystem::set_unknowns(Vec x)
{
  auto u = problem().u()->x();
  if (_constraint)
    _constraint->prolong(x, *u);
  else
  {
    VecCopy(x, _u_petsc);
    u->scatter_fwd();
  }
}

void DisplacementSystem::assemble_jacobian()
{
  MatZeroEntries(_A);
  for (MuscleProblem* part : _parts)
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(_A, ADD_VALUES), *part->jacobian(),
                         _bcs);
  close_jacobian();
}

void DisplacementSystem::close_jacobian()
{
  for (const auto& J : _extra_jacobians)
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(_A, ADD_VALUES), *J, _bcs);
  for (const auto& t : _terms)
    t->add_jacobian(_A);
  MatAssemblyBegin(_A, MAT_FLUSH_ASSEMBLY);
  MatAssemblyEnd(_A, MAT_FLUSH_ASSEMBLY);
  fem::set_diagonal<double>(la::petsc::Matrix::set_fn(_A, INSERT_VALUES), *problem().V(), _bcs);
  MatAssemblyBegin(_A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_A, MAT_FINAL_ASSEMBLY);
  _matrix_norm = finite_norm(_A);
}

void DisplacementSystem::reduce()
{
  PetscObjectState state;
  MatGetNonzeroState(_A, &state);
  // (MPIAIJ sums the nonzero state over the ranks at assembly, so every rank
  // takes the same, collective, branch)
  const bool changed = state != _reduced_state;
  if (!_A_red)
  {
    MatPtAP(_A, _constraint->T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, _A_red.out());
    MatSetBlockSize(_A_red, _reduced_bs);
    if (_term_F)
      MatSetOption(_A_red, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
  }
  else if (changed)
  {
    // A gained nonzeros (contact): a new product of our own, copied into the
    // reduced matrix (which the KSP holds).  Its own product data describe the
    // old pattern, so it is never recomputed in place again: a numeric PtAP on a
    // stale symbolic product reads past its arrays (crashed on 2 ranks).  The
    // later copies with SAME_NONZERO_PATTERN rely on A's pattern only growing
    // (contact adds entries, nothing removes them), so its pattern stays _ptap's.
    MatPtAP(_A, _constraint->T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, _ptap.out());
    MatSetBlockSize(_ptap, _reduced_bs);
    MatSetOption(_A_red, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
    MatCopy(_ptap, _A_red, DIFFERENT_NONZERO_PATTERN);
  }
  else if (_ptap)
  {
    MatPtAP(_A, _constraint->T(), MAT_REUSE_MATRIX, PETSC_DEFAULT, _ptap.address());
    MatCopy(_ptap, _A_red, SAME_NONZERO_PATTERN);
  }
  else
    MatPtAP(_A, _constraint->T(), MAT_REUSE_MATRIX, PETSC_DEFAULT, _A_red.address());
  _reduced_state = state;
}

void DisplacementSystem::drop_reduced()
{
  _A_red.reset();
  _ptap.reset();
}

void DisplacementSystem::multiply_reduced(const la::Vector<double>& w, Vec y)
{
  if (!_full_tmp)
    MatCreateVecs(_A, nullptr, _full_tmp.out());
  Vec wv = owned_part(w);
  MatMult(_A, wv, _full_tmp);
  VecDestroy(&wv);
  MatMultTranspose(_constraint->T(), _full_tmp, y);
}

void DisplacementSystem::assemble_nodal_forces(la::Vector<double>& b) const
{
  std::fill(b.mutable_array().begin(), b.mutable_array().end(), 0.0);
  for (MuscleProblem* part : _parts)
    fem::assemble_vector<double>(b.mutable_array(), *part->residual());
  for (const auto& r : _extra_residuals)
    fem::assemble_vector<double>(b.mutable_array(), *r);
  b.scatter_rev(std::plus<double>());
  add_term_residuals(b.mutable_array());
  b.scatter_fwd();
}

KernelStatus DisplacementSystem::update_activation()
{
  KernelStatus status;
  for (MuscleProblem* part : _parts)
  {
    const KernelStatus s = part->update_activation();
    if (status.failures == 0)
    {
      status.worst_cell = s.worst_cell;
      status.stretch = s.stretch;
    }
    status.failures += s.failures;
  }
  // every rank must take the same path through SNES (domain errors)
  MPI_Allreduce(MPI_IN_PLACE, &status.failures, 1, MPI_INT, MPI_SUM, comm());
  return status;
}

std::pair<double, std::int32_t> DisplacementSystem::min_jacobian_determinant() const
{
  std::pair<double, std::int32_t> worst{std::numeric_limits<double>::infinity(), -1};
  for (const MuscleProblem* part : _parts)
  {
    const auto m = part->min_jacobian_determinant();
    if (!(m.first >= worst.first))
      worst = m;
  }
  return worst;
}

double DisplacementSystem::boundary_change() const
{
  auto u = problem().u()->x();
  la::Vector<double> g(*u);
  std::span<double> ga = g.mutable_array();
  for (const auto& bc : _bcs)
    bc->set(ga);
  double moved = 0;
  const std::int32_t owned = u->map()->size_local() * u->bs();
  for (std::int32_t i = 0; i < owned; ++i)
    moved = std::max(moved, std::abs(ga[i] - u->array()[i]));
  MPI_Allreduce(MPI_IN_PLACE, &moved, 1, MPI_DOUBLE, MPI_MAX, comm());
  return moved;
}

} // namespace muscle
