// Taylor-Hood Newton: the SNES vector is [u owned | q owned] with q = (theta, p)
// the degree-1 field of the mixed element, the Jacobian the nest of the
// displacement block and the three blocks of q.
#include "fem/newton/taylor_hood_formulation.h"

#include "common/errors.h"
#include "fem/constraints/constraint.h"
#include "fem/linear/augmented_lagrangian.h"
#include "fem/linear/linear_solvers.h"
#include "fem/linear/taylor_hood_split.h"
#include "fem/newton/displacement_system.h"

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
std::int32_t owned_size(const la::Vector<double>& v)
{
  return v.map()->size_local() * v.bs();
}

/// The infinity norm of a nest of AIJ blocks, not assembled: per row, |a_ij| summed
/// over its block row (MatNorm takes a nest's Frobenius norm only).  uu is read in
/// place of the (u, u) block, which is an operator under the augmented Lagrangian:
/// A_gamma there, whose rows are larger than A's by the cells' terms.
double nest_infinity_norm(Mat nest, Mat uu)
{
  PetscInt rows, cols;
  Mat** blocks;
  MatNestGetSubMats(nest, &rows, &cols, &blocks);
  double largest = 0;
  for (PetscInt i = 0; i < rows; ++i)
  {
    PetscInt start, end;
    MatGetOwnershipRange(blocks[i][0], &start, &end);
    std::vector<double> sums(end - start, 0.0);
    for (PetscInt j = 0; j < cols; ++j)
      for (PetscInt r = start; r < end; ++r)
      {
        Mat block = i == 0 and j == 0 ? uu : blocks[i][j];
        PetscInt n;
        const PetscScalar* values;
        MatGetRow(block, r, &n, nullptr, &values);
        for (PetscInt k = 0; k < n; ++k)
          sums[r - start] += std::abs(values[k]);
        MatRestoreRow(block, r, &n, nullptr, &values);
      }
    for (double s : sums)
      largest = std::max(largest, s);
  }
  MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX,
                PetscObjectComm(reinterpret_cast<PetscObject>(nest)));
  return largest;
}
} // namespace

TaylorHoodFormulation::TaylorHoodFormulation(DisplacementSystem& system,
                                             const NewtonOptions& options)
    : _system(system)
{
  if (_system.parts().size() != 1)
    throw InputError("Taylor-Hood elements are built for a body of one material (one part)");
  const LinearSolverType& type = linear_solver_type(options.linear_solver);
  if (!type.blocks and !type.on_assembled_blocks)
    refuse_on_taylor_hood(type);
  MuscleProblem& problem = _system.problem();
  const DisplacementConstraint* constraint = _system.constraint();
  const DisplacementSpace space{problem.V(), constraint};
  if (type.blocks)
    _split = type.blocks(options, space, _system.bcs(), problem.parameters(),
                         problem.kernel_name());
  else
  {
    refuse_taylor_hood_split_options(true, options.linear_solver);
    _direct = type.matrix(options, space);
  }
  _x = _system.create_unknowns();
  const MuscleProblem::TaylorHoodForms& f = problem.th_forms();
  auto Q = problem.th_state()->function_space();
  _bq = std::make_unique<la::Vector<double>>(Q->dofmap()->index_map,
                                             Q->dofmap()->index_map_bs());
  *_blocks[0].out() = fem::petsc::create_matrix(*f.jacobian_uq, "aij");
  *_blocks[1].out() = fem::petsc::create_matrix(*f.jacobian_qu, "aij");
  *_blocks[2].out() = fem::petsc::create_matrix(*f.jacobian_qq, "aij");
  PetscInt n;
  VecGetLocalSize(_x, &n);
  VecCreateMPI(_system.comm(), n + owned_size(*_bq), PETSC_DETERMINE, _x_ext.out());
  VecDuplicate(_x, _tmp.out());
  // the nest and its assembled copy need the patterns before SNES holds them
  problem.u()->x()->scatter_fwd();
  _system.update_activation();
  jacobian();
}

TaylorHoodFormulation::~TaylorHoodFormulation() = default;

const LinearSolver& TaylorHoodFormulation::linear_solver() const
{
  return _split ? static_cast<const LinearSolver&>(*_split) : *_direct;
}

void TaylorHoodFormulation::start_clean()
{
  _split ? _split->start_solve() : _direct->start_solve();
}

Mat TaylorHoodFormulation::matrix() const
{
  return _J_mixed ? _J_mixed.get() : _J_nest.get(); // the nest under GMRES
}

void TaylorHoodFormulation::configure_linear_solver(KSP ksp)
{
  if (_direct)
  {
    _direct->configure(ksp);
    return;
  }
  PetscInt n;
  VecGetLocalSize(_x, &n);
  const DisplacementConstraint* constraint = _system.constraint();
  TaylorHoodBlocks blocks;
  blocks.uu = constraint ? _system.reduced() : _system.A();
  blocks.uq = constraint ? _reduced[0].get() : _blocks[0].get();
  blocks.qu = constraint ? _reduced[1].get() : _blocks[1].get();
  blocks.qq = _blocks[2];
  blocks.iterate = _x_ext;
  blocks.nu = n;
  _split->configure(ksp, blocks);
}

void TaylorHoodFormulation::reduce_coupling_blocks(bool first)
{
  // products of their own, recomputed in place later
  Mat T = _system.constraint()->T();
  if (first)
  {
    MatTransposeMatMult(T, _blocks[0], MAT_INITIAL_MATRIX, PETSC_DEFAULT, _reduced[0].out());
    MatMatMult(_blocks[1], T, MAT_INITIAL_MATRIX, PETSC_DEFAULT, _reduced[1].out());
  }
  else
  {
    MatTransposeMatMult(T, _blocks[0], MAT_REUSE_MATRIX, PETSC_DEFAULT, _reduced[0].address());
    MatMatMult(_blocks[1], T, MAT_REUSE_MATRIX, PETSC_DEFAULT, _reduced[1].address());
  }
}

KernelStatus TaylorHoodFormulation::set_state(Vec x)
{
  PetscInt n;
  VecGetLocalSize(_x, &n);
  const PetscScalar* a;
  VecGetArrayRead(x, &a);
  // q first: the activation kernels read the fibre stretch at F_bar
  MuscleProblem& problem = _system.problem();
  auto q = problem.th_state()->x();
  std::copy(a + n, a + n + owned_size(*q), q->mutable_array().begin());
  q->scatter_fwd();
  PetscScalar* xu;
  VecGetArray(_x, &xu);
  std::copy(a, a + n, xu);
  VecRestoreArray(_x, &xu);
  VecRestoreArrayRead(x, &a);
  _system.set_unknowns(_x);
  return _system.update_activation();
}

void TaylorHoodFormulation::start()
{
  MuscleProblem& problem = _system.problem();
  const DisplacementConstraint* constraint = _system.constraint();
  _system.get_unknowns(_x);
  PetscInt n;
  VecGetLocalSize(_x, &n);
  PetscScalar* a;
  VecGetArray(_x_ext, &a);
  std::span<const double> u = problem.u()->x()->array();
  std::copy(u.begin(), u.begin() + n, a);
  auto q = problem.th_state()->x();
  std::copy(q->array().begin(), q->array().begin() + owned_size(*q), a + n);
  VecRestoreArray(_x_ext, &a);
  if (constraint)
  {
    constraint->restrict_to(*problem.u()->x(), _tmp);
    const PetscScalar* t;
    VecGetArrayRead(_tmp, &t);
    VecGetArray(_x_ext, &a);
    std::copy(t, t + n, a);
    VecRestoreArray(_x_ext, &a);
    VecRestoreArrayRead(_tmp, &t);
  }
}

void TaylorHoodFormulation::residual(Vec F)
{
  _system.residual();
  MuscleProblem& problem = _system.problem();
  const MuscleProblem::TaylorHoodForms& f = problem.th_forms();
  std::span<double> bq = _bq->mutable_array();
  std::fill(bq.begin(), bq.end(), 0.0);
  fem::assemble_vector<double>(bq, *f.residual);
  // q has no Dirichlet conditions; its rows see the displacement's through dR_q/du
  fem::apply_lifting<double>(bq, {f.jacobian_qu}, {_system.bcs()}, {problem.u()->x()->array()},
                             -1.0);
  _bq->scatter_rev(std::plus<double>());
  PetscInt n;
  VecGetLocalSize(_x, &n);
  _system.restrict_residual(_tmp);
  const PetscScalar* t;
  VecGetArrayRead(_tmp, &t);
  PetscScalar* a;
  VecGetArray(F, &a);
  std::copy(t, t + n, a);
  VecRestoreArrayRead(_tmp, &t);
  std::copy(bq.begin(), bq.begin() + owned_size(*_bq), a + n);
  VecRestoreArray(F, &a);
}

void TaylorHoodFormulation::jacobian()
{
  _system.assemble_jacobian();
  const MuscleProblem::TaylorHoodForms& f = _system.problem().th_forms();
  const std::array<const fem::Form<double>*, 3> forms
      = {f.jacobian_uq.get(), f.jacobian_qu.get(), f.jacobian_qq.get()};
  bool finite = std::isfinite(_system.matrix_norm());
  AugmentedLagrangian* augmented = _split ? _split->augmented() : nullptr;
  if (augmented)
    augmented->begin(_system.A());
  // A_qq before A_qu: the augmented Lagrangian takes each cell's lumped mass from
  // the one and sums B_c^T W_c^-1 B_c from the other, cell by cell
  for (std::size_t i : {0, 2, 1})
  {
    Mat M = _blocks[i];
    MatZeroEntries(M);
    auto set = la::petsc::Matrix::set_block_fn(M, ADD_VALUES);
    auto add = [&set, augmented, i](const std::span<const std::int32_t>& rows,
                                    const std::span<const std::int32_t>& cols,
                                    const std::span<const double>& values)
    {
      if (augmented and i == 2)
        augmented->add_cell_mass(rows, values);
      else if (augmented and i == 1)
        augmented->add_cell_coupling(rows, cols, values);
      return set(rows, cols, values);
    };
    // Dirichlet rows (of A_uq) and columns (of A_qu) zeroed: A carries unit rows there
    fem::assemble_matrix(add, *forms[i], _system.bcs());
    MatAssemblyBegin(M, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(M, MAT_FINAL_ASSEMBLY);
    PetscReal norm;
    MatNorm(M, NORM_FROBENIUS, &norm);
    finite = finite and std::isfinite(norm);
  }
  if (augmented)
    augmented->end(_blocks[2]);
  if (!finite)
  {
    _system.set_matrix_norm(std::numeric_limits<double>::quiet_NaN());
    return;
  }
  const bool first = !_J_nest;
  const DisplacementConstraint* constraint = _system.constraint();
  Mat A = _system.A();
  std::array<Mat, 2> coupling = {_blocks[0], _blocks[1]};
  if (constraint)
  {
    _system.reduce();
    reduce_coupling_blocks(first);
    A = _system.reduced();
    coupling = {_reduced[0], _reduced[1]};
  }
  if (first)
  {
    // with the augmented Lagrangian A holds A_gamma, and GMRES's block is A_gamma
    // less the cells' terms, an operator
    Mat uu = augmented ? augmented->jacobian_block(A, constraint ? constraint->T() : nullptr)
                       : A;
    Mat blocks[4] = {uu, coupling[0], coupling[1], _blocks[2]};
    MatCreateNest(_system.comm(), 2, nullptr, 2, nullptr, blocks, _J_nest.out());
  }
  MatAssemblyBegin(_J_nest, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_J_nest, MAT_FINAL_ASSEMBLY);
  // GMRES takes the nest as it is (the split's blocks are the nest's, not copies)
  if (_direct)
  {
    // MUMPS needs the blocks in one matrix; contact can add nonzeros to A, and a
    // conversion reusing the old pattern would drop them
    PetscObjectState state;
    MatGetNonzeroState(A, &state);
    if (!_J_mixed)
      MatConvert(_J_nest, MATAIJ, MAT_INITIAL_MATRIX, _J_mixed.out());
    else if (state != _mixed_state)
    {
      MatHandle fresh;
      MatConvert(_J_nest, MATAIJ, MAT_INITIAL_MATRIX, fresh.out());
      MatSetOption(_J_mixed, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
      MatCopy(fresh, _J_mixed, DIFFERENT_NONZERO_PATTERN);
    }
    else
      MatConvert(_J_nest, MATAIJ, MAT_REUSE_MATRIX, _J_mixed.address());
    _mixed_state = state;
    MatNorm(_J_mixed, NORM_INFINITY, &_mixed_norm);
  }
  else
    _mixed_norm = nest_infinity_norm(_J_nest, A);
  if (_split)
    _split->update();
}

double TaylorHoodFormulation::matrix_norm() const { return _system.matrix_norm(); }

double TaylorHoodFormulation::convergence_floor(SNES snes, double) const
{
  // The q rows carry the stiff penalty (kappa per unit volume), and the degree-1
  // basis sums to one only to round-off, so R_theta cannot fall below about
  // eps |A_mixed| |theta| (measured on the cantilever at rest); the displacement
  // rows as in the other elements, eps |A| |u|.  (theta, not p: p's round-off
  // enters through the small coupling blocks only.)
  Vec x;
  SNESGetSolution(snes, &x);
  PetscInt n;
  VecGetLocalSize(_x, &n);
  PetscInt size;
  VecGetLocalSize(x, &size);
  const PetscScalar* a;
  VecGetArrayRead(x, &a);
  double sums[2] = {0, 0};
  for (PetscInt i = 0; i < n; ++i)
    sums[0] += a[i] * a[i];
  for (PetscInt i = n; i < size; i += 2)
    sums[1] += a[i] * a[i];
  VecRestoreArrayRead(x, &a);
  MPI_Allreduce(MPI_IN_PLACE, sums, 2, MPI_DOUBLE, MPI_SUM, _system.comm());
  return 100
         * (std::numeric_limits<double>::epsilon()
            * (_system.matrix_norm() * std::sqrt(sums[0]) + _mixed_norm * std::sqrt(sums[1])));
}

void TaylorHoodFormulation::converged()
{
  auto q = _system.problem().th_state()->x();
  _q_converged.assign(q->array().begin(), q->array().begin() + q->map()->size_local() * q->bs());
}

void TaylorHoodFormulation::restore()
{
  // the restored u is the last converged state's (a cut step): so is its q
  MuscleProblem& problem = _system.problem();
  auto q = problem.th_state()->x();
  if (_q_converged.empty())
    problem.reset_th_state();
  else
    std::copy(_q_converged.begin(), _q_converged.end(), q->mutable_array().begin());
  q->scatter_fwd();
}

Mat TaylorHoodFormulation::system_matrix()
{
  return _system.constraint() ? _system.reduced() : _system.A();
}

Mat TaylorHoodFormulation::assemble_tangent()
{
  throw InputError("the tangent of Taylor-Hood elements holds the pressure: natural "
                   "frequencies need a displacement element (element.taylor_hood: false)");
}

} // namespace muscle
