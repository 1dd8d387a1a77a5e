// "gmres-schur": the condensed F-bar system solved through its saddle form.  With B's
// rows the cells' g_c^T and D = diag(K00_c), the condensed tangent is K = A + B^T D B,
// the stiff penalty being the rank-one cell terms.  Each cell keeps the share s_c of its
// penalty in a soft matrix A_s = K - B^T D_r B, D_r = diag((1 - s_c) K00_c), the kept
// share at most `ratio` times the rest of the cell's diagonal, so that multigrid sees a
// matrix of moderate penalty whatever kappa is.  K du = b is then
//
//     [ A_s    B^T ] [du]   [b]
//     [ D_r B  -I  ] [q ] = [0],     q per cell,
//
// which GMRES solves preconditioned by a block factorisation, A_s^-1 by one V-cycle and
// the Schur complement I + D_r B A_s^-1 B^T by its diagonal,
// I + D_r diag_c(sum_j g_cj^2 / A_s,jj).  The lower (default) and upper triangular
// factors need one V-cycle per Krylov iteration, the full factorisation two; on the
// fusiform the full one saves far fewer Krylov iterations than the V-cycles it adds
// (BENCHMARKS.md, "Preconditioners against kappa").  Dirichlet rows of B^T are zero: K keeps
// identity rows there.  Krylov on K itself with the same preconditioner (Woodbury) is
// worse: its error term carries D B A_s^-1 B^T, which grows with kappa.  Measured
// (BENCHMARKS.md, "Preconditioners against kappa"): the count still grows with kappa
// (the diagonal misses the Q1-P0 pressure modes), but slower than GAMG's on K, and the
// preset penalty and 10^4 converge where GAMG fails.  Scaling the q rows by 1/K00 made
// the count flat on a small block but let GMRES stop with the condensed residual up to
// kappa times the tolerance (more Newton iterations, failures at 10^4 on the fusiform).
// `-penalty_split_schur sparse` keeps the whole cell matrix I + D_r B diag(A_s)^-1 B^T
// (PETSc's "selfp", with the full layout's diagonal also under a constraint), which, like
// the exact complement and unlike the diagonal, is close to I on the modes with
// B^T q ~ 0; measured, it needs more Krylov iterations than its diagonal (BENCHMARKS.md,
// "Preconditioners against kappa"):
// diag(A_s)^-1 is far from A_s^-1 on smooth pressures.
#include "fem/linear/penalty_split.h"

#include "common/errors.h"
#include "common/petsc_options.h"
#include "fem/constraints/constraint.h"
#include "fem/elements/fbar_unknowns.h"
#include "fem/linear/linear_failure.h"
#include "fem/linear/rigid_body_modes.h"
#include "fem/linear/saddle_parts.h"

#include <algorithm>
#include <cmath>
#include <dolfinx/la/petsc.h>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// The diagonal of a full-layout matrix into w (unrolled, ghosts updated).
void diagonal(Mat A, la::Vector<double>& w)
{
  Vec d;
  MatCreateVecs(A, &d, nullptr);
  MatGetDiagonal(A, d);
  const PetscScalar* a;
  PetscInt n;
  VecGetLocalSize(d, &n);
  VecGetArrayRead(d, &a);
  std::copy(a, a + n, w.mutable_array().begin());
  VecRestoreArrayRead(d, &a);
  VecDestroy(&d);
  w.scatter_fwd();
}

/// Calls f(part, cell, g, dofs, fixed) for every cell of every part; g and dofs are
/// the cell's n entries.
template <typename F>
void for_each_cell(const std::vector<std::unique_ptr<FbarCellUnknowns>>& parts, F f)
{
  for (std::size_t part = 0; part < parts.size(); ++part)
  {
    const FbarElement::CellData& d = parts[part]->linearisation();
    std::span<const std::int32_t> dofs = parts[part]->cell_dofs();
    for (std::size_t i = 0; i < d.K00.size(); ++i)
      f(part, i, std::span<const double>(d.g.data() + i * d.n, d.n),
        dofs.subspan(i * d.n, d.n), parts[part]->fixed());
  }
}

/// B and B^T over the cells at once: for each cell (in saddle order k from `k`)
/// s = f(part, cell, k, (B u)_cell), then w += s g on the cell's free dofs.  Either
/// half can be left out: without B, f gets 0 for (B u)_cell; without B^T, w is untouched.
template <bool with_B, bool with_BT, typename F>
void apply_B_and_BT(const std::vector<std::unique_ptr<FbarCellUnknowns>>& parts,
                    std::span<const double> u, std::span<double> w, PetscInt k, F f)
{
  for_each_cell(parts, [&](std::size_t part, std::size_t i, auto g, auto dofs, auto fixed)
  {
    double Bu = 0;
    if constexpr (with_B)
      for (std::size_t j = 0; j < g.size(); ++j)
        Bu += g[j] * u[dofs[j]];
    const double scale = f(part, i, k++, Bu);
    if constexpr (with_BT)
      for (std::size_t j = 0; j < g.size(); ++j)
        if (!fixed[dofs[j]])
          w[dofs[j]] += g[j] * scale;
  });
}

} // namespace

PenaltySplit::PenaltySplit(const LinearSettings& settings, DisplacementSpace space,
                           const std::vector<std::unique_ptr<FbarCellUnknowns>>& cells, Mat A,
                           Vec layout)
    : _settings(settings), _space(std::move(space)), _cells(cells), _A(A),
      _work(_space.V->dofmap()->index_map, _space.V->dofmap()->index_map_bs()), _work2(_work)
{
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(A));
  *_modes.out() = rigid_body_modes(*_space.V, _space.constraint,
                                   _settings.near_null_space == "bodies");
  PetscOptionsGetReal(nullptr, nullptr, "-penalty_split_ratio", &_split_ratio, nullptr);
  if (!(_split_ratio > 0))
    throw InputError("-penalty_split_ratio must be > 0");
  choice_option("-penalty_split_factorization", {"lower", "upper", "full"},
                _split_factorization);
  choice_option("-penalty_split_schur", {"diagonal", "sparse"}, _split_schur);
  KSPCreate(comm, _soft.out());
  // -soft_pc_gamg_* etc. tune the multigrid of the soft matrix
  KSPSetOptionsPrefix(_soft, "soft_");
  KSPSetType(_soft, KSPPREONLY);
  PC pc;
  KSPGetPC(_soft, &pc);
  PCSetType(pc, PCGAMG);
  KSPSetFromOptions(_soft);
  require_flexible_outer_under("soft_", "penalty split");
  VecDuplicate(layout, _soft_r.out());

  PetscInt nu, nq = 0;
  VecGetLocalSize(layout, &nu);
  _split.resize(_cells.size());
  _schur_h.resize(_cells.size());
  for (std::size_t part = 0; part < _cells.size(); ++part)
  {
    const std::size_t cells = _cells[part]->linearisation().K00.size();
    _split[part].assign(cells, 0.0);
    _schur_h[part].assign(cells, 0.0);
    nq += cells;
  }
  if (_split_schur == "sparse")
  {
    KSPCreate(comm, _schur.out());
    // -schur_pc_* tune the solve of the sparse Schur complement (a cell-by-cell matrix)
    KSPSetOptionsPrefix(_schur, "schur_");
    KSPSetType(_schur, KSPPREONLY);
    KSPGetPC(_schur, &pc);
    PCSetType(pc, PCGAMG);
    KSPSetFromOptions(_schur);
    require_flexible_outer_under("schur_", "penalty split");
    VecCreateMPI(comm, nq, PETSC_DETERMINE, _schur_rhs.out());
    VecDuplicate(_schur_rhs, _schur_w.out());
  }
  VecCreateMPI(comm, nu + nq, PETSC_DETERMINE, _saddle_b.out());
  VecDuplicate(_saddle_b, _saddle_x.out());
  VecCreateMPIWithArray(comm, 1, nu, PETSC_DETERMINE, nullptr, _part_in.out());
  VecCreateMPIWithArray(comm, 1, nu, PETSC_DETERMINE, nullptr, _part_out.out());
  MatCreateShell(comm, nu + nq, nu + nq, PETSC_DETERMINE, PETSC_DETERMINE, this, _saddle.out());
  MatShellSetOperation(_saddle, MATOP_MULT, (void (*)(void))saddle_multiply);
}

PenaltySplit::~PenaltySplit() = default;

void PenaltySplit::configure(KSP ksp)
{
  _ksp = ksp;
  configure_gmres(ksp, _settings.linear_rtol);
  PC pc;
  KSPGetPC(ksp, &pc);
  PCSetType(pc, PCSHELL);
  PCShellSetContext(pc, this);
  PCShellSetApply(pc, apply);
  PCShellSetName(pc, "penalty split: V-cycles on the soft matrix, diagonal Schur");
  // the residual GMRES tests is the true one (the saddle form's q rows included)
  KSPSetPCSide(ksp, PC_RIGHT);
}

void PenaltySplit::update()
{
  // the penalty's share of K's diagonal, sum_c K00_c g_cj^2, and the rest of it
  std::span<double> penalty = _work2.mutable_array();
  std::fill(penalty.begin(), penalty.end(), 0.0);
  for_each_cell(_cells, [&](std::size_t part, std::size_t i, auto g, auto dofs, auto fixed)
  {
    const double K00 = _cells[part]->linearisation().K00[i];
    for (std::size_t j = 0; j < g.size(); ++j)
      if (!fixed[dofs[j]])
        penalty[dofs[j]] += K00 * g[j] * g[j];
  });
  _work2.scatter_rev(std::plus<double>());
  _work2.scatter_fwd();
  diagonal(_A, _work);

  PetscObjectState state;
  MatGetNonzeroState(_A, &state);
  if (_A_soft and state != _soft_state)
    _A_soft.reset(); // _A gained nonzeros
  if (!_A_soft)
  {
    MatDuplicate(_A, MAT_COPY_VALUES, _A_soft.out());
    ISLocalToGlobalMapping rows, cols;
    MatGetLocalToGlobalMapping(_A, &rows, &cols);
    MatSetLocalToGlobalMapping(_A_soft, rows, cols);
    _soft_state = state;
    _A_soft_red.reset();
  }
  else
    MatCopy(_A, _A_soft, SAME_NONZERO_PATTERN);

  std::vector<PetscInt> index;
  std::vector<double> block;
  for_each_cell(_cells, [&](std::size_t part, std::size_t i, auto g, auto dofs, auto fixed)
  {
    const double K00 = _cells[part]->linearisation().K00[i];
    const std::size_t n = g.size();
    double own = 0, rest = 0;
    for (std::size_t j = 0; j < n; ++j)
      if (!fixed[dofs[j]])
      {
        own += K00 * g[j] * g[j];
        rest += _work.array()[dofs[j]] - penalty[dofs[j]];
      }
    double& removed = _split[part][i];
    removed = 0;
    if (!(K00 > 0 and own > 0 and rest > 0))
      return; // nothing stiff to take out, or no soft part to measure it by
    removed = (1 - std::min(1.0, _split_ratio * rest / own)) * K00;
    if (removed == 0)
      return;
    index.assign(dofs.begin(), dofs.end());
    block.resize(n * n);
    for (std::size_t j = 0; j < n; ++j)
    {
      // Dirichlet rows stay identity rows: their entries get zeros
      const double row = fixed[dofs[j]] ? 0.0 : -removed * g[j];
      for (std::size_t k = 0; k < n; ++k)
        block[j * n + k] = row * g[k];
    }
    MatSetValuesLocal(_A_soft, n, index.data(), n, index.data(), block.data(), ADD_VALUES);
  });
  MatAssemblyBegin(_A_soft, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_A_soft, MAT_FINAL_ASSEMBLY);

  Mat M = _A_soft;
  if (_space.constraint)
  {
    const bool first = !_A_soft_red;
    MatPtAP(_A_soft, _space.constraint->T(), first ? MAT_INITIAL_MATRIX : MAT_REUSE_MATRIX,
            PETSC_DEFAULT, first ? _A_soft_red.out() : _A_soft_red.address());
    if (first)
      MatSetNearNullSpace(_A_soft_red, _modes);
    M = _A_soft_red;
  }
  else
    MatSetNearNullSpace(_A_soft, _modes);
  KSPSetOperators(_soft, M, M);
  KSPSetOperators(_ksp, _saddle, _saddle);

  // diag_c(B A_s^-1 B^T) by the diagonal of A_s (full layout, also when constrained)
  diagonal(_A_soft, _work);
  if (_split_schur == "sparse")
    return update_sparse_schur(_work.array());
  for_each_cell(_cells, [&](std::size_t part, std::size_t i, auto g, auto dofs, auto fixed)
  {
    double h = 0;
    for (std::size_t j = 0; j < g.size(); ++j)
      if (!fixed[dofs[j]])
        h += g[j] * g[j] / _work.array()[dofs[j]];
    _schur_h[part][i] = h;
  });
}

void PenaltySplit::update_sparse_schur(std::span<const double> d)
{
  // C = D_r^1/2 B diag(A_s)^-1/2 on the free dofs, then I + C C^T.  Every entry is
  // inserted, zeros too: a cell that lost its removed share must lose last update's row.
  _soft_diagonal.assign(d.begin(), d.end());
  ISLocalToGlobalMapping cols;
  MatGetLocalToGlobalMapping(_A, nullptr, &cols);
  PetscInt owned_dofs;
  MatGetLocalSize(_A, &owned_dofs, nullptr);
  PetscInt nq, first;
  VecGetLocalSize(_schur_rhs, &nq);
  VecGetOwnershipRange(_schur_rhs, &first, nullptr);
  if (!_schur_factor)
  {
    std::vector<PetscInt> diagonal_nnz(nq, 0), off_nnz(nq, 0);
    PetscInt k = 0;
    for_each_cell(_cells, [&](std::size_t, std::size_t, auto, auto dofs, auto fixed)
    {
      for (std::int32_t j : dofs)
        if (!fixed[j])
          ++(j < owned_dofs ? diagonal_nnz : off_nnz)[k];
      ++k;
    });
    MatCreateAIJ(PetscObjectComm(reinterpret_cast<PetscObject>(_A)), nq, owned_dofs, PETSC_DETERMINE, PETSC_DETERMINE, 0,
                 diagonal_nnz.data(), 0, off_nnz.data(), _schur_factor.out());
  }
  std::vector<PetscInt> local, global;
  std::vector<double> values;
  PetscInt k = first;
  for_each_cell(_cells, [&](std::size_t part, std::size_t i, auto g, auto dofs, auto fixed)
  {
    const double p = std::sqrt(_split[part][i]);
    local.clear();
    values.clear();
    for (std::size_t j = 0; j < g.size(); ++j)
      if (!fixed[dofs[j]])
      {
        local.push_back(dofs[j]);
        values.push_back(p * g[j] / std::sqrt(d[dofs[j]]));
      }
    global.resize(local.size());
    ISLocalToGlobalMappingApply(cols, local.size(), local.data(), global.data());
    MatSetValues(_schur_factor, 1, &k, global.size(), global.data(), values.data(),
                 INSERT_VALUES);
    ++k;
  });
  MatAssemblyBegin(_schur_factor, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_schur_factor, MAT_FINAL_ASSEMBLY);
  // formed anew: with MAT_REUSE_MATRIX the product kept stale values on two ranks
  // (observed with PETSc 3.18; GMRES then failed; not reduced to a reproducer)
  MatMatTransposeMult(_schur_factor, _schur_factor, MAT_INITIAL_MATRIX, PETSC_DEFAULT,
                      _schur_sym.out());
  MatShift(_schur_sym, 1.0);
  KSPSetOperators(_schur, _schur_sym, _schur_sym);
}

bool PenaltySplit::sparse_schur_solve(PetscScalar* q)
{
  // S = I + P^2 H with P = D_r^1/2, H = B diag(A_s)^-1 B^T, and S_sym = I + P H P:
  // q <- q - P w with S_sym w = P H q (q's cells without a removed share stay as they are)
  std::span<double> w = _work2.mutable_array();
  std::fill(w.begin(), w.end(), 0.0);
  apply_B_and_BT<false, true>(_cells, {}, w, 0,
                              [&](std::size_t, std::size_t, PetscInt k, double) { return q[k]; });
  _work2.scatter_rev(std::plus<double>());
  _work2.scatter_fwd();
  for (std::size_t j = 0; j < w.size(); ++j)
    w[j] /= _soft_diagonal[j];
  PetscScalar* rhs;
  VecGetArray(_schur_rhs, &rhs);
  apply_B_and_BT<true, false>(_cells, w, {}, 0,
                              [&](std::size_t part, std::size_t i, PetscInt k, double Bw)
  {
    rhs[k] = std::sqrt(_split[part][i]) * Bw;
    return 0.0;
  });
  VecRestoreArray(_schur_rhs, &rhs);
  const PetscErrorCode error = KSPSolve(_schur, _schur_rhs, _schur_w);
  KSPConvergedReason reason = KSP_DIVERGED_PC_FAILED;
  if (!error)
    KSPGetConvergedReason(_schur, &reason);
  if (inner_solve_failed(reason))
  {
    _inner_failure = "sparse Schur: " + describe_linear_failure(_schur, error);
    return false;
  }
  const PetscScalar* x;
  VecGetArrayRead(_schur_w, &x);
  PetscInt k = 0;
  for (const auto& split : _split)
    for (const double removed : split)
    {
      q[k] -= std::sqrt(removed) * x[k];
      ++k;
    }
  VecRestoreArrayRead(_schur_w, &x);
  return true;
}

std::pair<PetscErrorCode, PetscInt> PenaltySplit::solve(Vec rhs, Vec sol)
{
  // (b, 0) -> (du, q)
  PetscScalar* s;
  VecGetArray(_saddle_b, &s);
  const PetscScalar* b;
  PetscInt nu, n;
  VecGetLocalSize(rhs, &nu);
  VecGetLocalSize(_saddle_b, &n);
  VecGetArrayRead(rhs, &b);
  std::copy(b, b + nu, s);
  std::fill(s + nu, s + n, 0.0);
  VecRestoreArrayRead(rhs, &b);
  VecRestoreArray(_saddle_b, &s);
  VecSet(_saddle_x, 0.0);
  const PetscErrorCode error = KSPSolve(_ksp, _saddle_b, _saddle_x);
  PetscInt its = 0;
  KSPGetIterationNumber(_ksp, &its);
  const PetscScalar* x;
  VecGetArrayRead(_saddle_x, &x);
  PetscScalar* du;
  VecGetArray(sol, &du);
  std::copy(x, x + nu, du);
  VecRestoreArray(sol, &du);
  VecRestoreArrayRead(_saddle_x, &x);
  return {error, its};
}

PetscErrorCode PenaltySplit::saddle_multiply(Mat M, Vec v, Vec y)
{
  PenaltySplit* self;
  MatShellGetContext(M, &self);
  SaddleParts parts(v, y, self->_part_in, self->_part_out);
  const PetscScalar* vv = parts.x;
  PetscScalar* yy = parts.y;
  // y_u = A_s u + B^T q,  y_q = D_r B u - q
  MatMult(self->_space.constraint ? self->_A_soft_red : self->_A_soft, self->_part_in, self->_part_out);
  to_full(self->_space.constraint, self->_part_in, self->_work);
  std::span<const double> u = self->_work.array();
  std::span<double> w = self->_work2.mutable_array();
  std::fill(w.begin(), w.end(), 0.0);
  apply_B_and_BT<true, true>(self->_cells, u, w, parts.nu,
                             [&](std::size_t part, std::size_t i, PetscInt k, double Bu)
  {
    yy[k] = self->_split[part][i] * Bu - vv[k];
    return vv[k];
  });
  self->_work2.scatter_rev(std::plus<double>());
  add_restricted(self->_space.constraint, self->_work2, self->_part_out);
  return 0;
}

PetscErrorCode PenaltySplit::apply(PC pc, Vec r, Vec z)
{
  PenaltySplit* self;
  PCShellGetContext(pc, &self);
  // a failure reaches the Krylov method as Inf in z, written once z's parts are
  // given back (declared before them)
  struct ReportFailure
  {
    PC pc;
    Vec z;
    bool failed = false;
    ~ReportFailure()
    {
      if (failed)
        fail_shell_apply(pc, z);
    }
  } report{pc, z};
  auto soft_solve = [&](Vec b, Vec x)
  {
    const PetscErrorCode error = KSPSolve(self->_soft, b, x);
    KSPConvergedReason reason = KSP_DIVERGED_PC_FAILED;
    if (!error)
      KSPGetConvergedReason(self->_soft, &reason);
    if (inner_solve_failed(reason))
    {
      report.failed = true;
      self->_inner_failure = "soft block: " + describe_linear_failure(self->_soft, error);
    }
  };
  SaddleParts parts(r, z, self->_part_in, self->_part_out);
  const PetscScalar* rr = parts.x;
  PetscScalar* zz = parts.y;
  std::span<double> w = self->_work2.mutable_array();
  const std::string& factorization = self->_split_factorization;
  // q = S^-1 (D_r B x1 - r_q), without B x1 for the upper factor
  auto schur_rhs = [&](std::size_t part, std::size_t i, PetscInt k, double Bx)
  {
    zz[k] = self->_split[part][i] * Bx - rr[k];
    return 0.0;
  };
  auto schur_solve = [&]
  {
    PetscScalar* q = zz + parts.nu;
    if (self->_split_schur == "sparse")
    {
      if (!self->sparse_schur_solve(q))
        report.failed = true;
      return;
    }
    PetscInt k = 0;
    for (std::size_t part = 0; part < self->_split.size(); ++part)
      for (std::size_t i = 0; i < self->_split[part].size(); ++i, ++k)
        q[k] /= 1 + self->_split[part][i] * self->_schur_h[part][i];
  };
  if (factorization == "upper")
    // q = -S^-1 r_q;  z_u = A_s^-1 (r_u - B^T q)
    apply_B_and_BT<false, false>(self->_cells, {}, {}, parts.nu, schur_rhs);
  else
  {
    // x1 = A_s^-1 r_u;  q as above;  full: z_u = A_s^-1 (r_u - B^T q),
    // lower: z_u = x1 (x1 lands in z_u; the full factor's second solve overwrites it)
    soft_solve(self->_part_in, self->_part_out);
    to_full(self->_space.constraint, self->_part_out, self->_work);
    apply_B_and_BT<true, false>(self->_cells, self->_work.array(), {}, parts.nu,
                                schur_rhs);
  }
  schur_solve();
  if (factorization == "lower")
    return 0;
  std::fill(w.begin(), w.end(), 0.0);
  apply_B_and_BT<false, true>(self->_cells, {}, w, parts.nu,
                              [&](std::size_t, std::size_t, PetscInt k, double)
                              { return -zz[k]; });
  self->_work2.scatter_rev(std::plus<double>());
  VecCopy(self->_part_in, self->_soft_r);
  add_restricted(self->_space.constraint, self->_work2, self->_soft_r);
  soft_solve(self->_soft_r, self->_part_out);
  return 0;
}

} // namespace muscle
