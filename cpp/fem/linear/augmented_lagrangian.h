#pragma once

#include "common/petsc_handle.h"

#include <cstdint>
#include <petscmat.h>
#include <span>
#include <vector>

namespace muscle
{

/// The augmented-Lagrangian form of the Taylor-Hood system for its block
/// preconditioner.  Under activation the displacement block A (theta held) can
/// be indefinite (at a step's first Newton iteration, measured): with theta held
/// a dilation costs no bulk energy, and the fibre stress makes some dilational
/// fields lower the energy.  Adding gamma B^T W^-1 times the constraint rows
/// (p: the L2 projection of J onto theta) to the displacement rows gives the
/// block a bulk stiffness back; B: the p rows of dR_q/du, W: the degree-1 mass
/// matrix lumped.  The system solved is unchanged (GMRES sees the Jacobian); only
/// the preconditioner's blocks are.
///
/// Two W's, on purpose.  The block is the per-cell variant, A_gamma = A + gamma
/// sum_c B_c^T W_c^-1 B_c with W_c a cell's own lumped mass: it keeps A's
/// sparsity, where the global B^T W^-1 B couples every displacement dof with
/// those of the 4 x 4 x 4 cells around it, six times A's nonzeros
/// (BENCHMARKS.md, "Preconditioners against kappa").  The constraint rows' share
/// in the right-hand side is a product with vectors, so it uses the global W.
///
/// One assembled Q2 matrix, not two.  A_gamma is summed into A's own storage, and
/// GMRES's A is the operator A_gamma - gamma B_b^T W_b^-1 B_b (jacobian_block),
/// with B_b the cells' p rows side by side (one row per cell and node, "broken")
/// and W_b their cells' lumped masses: B_b has 8 rows of 81 entries per cell
/// where A has about 24 of 180, a seventh of A's storage (BENCHMARKS.md,
/// "Preconditioners against kappa").
class AugmentedLagrangian
{
public:
  /// gamma: the penalty in the units of the stiffness (kPa), > 0
  explicit AugmentedLagrangian(double gamma) : _gamma(gamma) {}
  AugmentedLagrangian(const AugmentedLagrangian&) = delete;
  AugmentedLagrangian& operator=(const AugmentedLagrangian&) = delete;

  double gamma() const { return _gamma; }

  /// A, just assembled (local-to-global map with block size 3), becomes A_gamma
  /// in place.  Then add_cell_mass for every cell of A_qq's assembly and
  /// add_cell_coupling for every cell of A_qu's, in the same cell order, with the
  /// blocked local dofs and row-major element matrices that DOLFINx's assembler
  /// hands on (q = (theta, p) interleaved per degree-1 node, block size 2; u: 3).
  void begin(Mat A);
  void add_cell_mass(std::span<const std::int32_t> q_dofs, std::span<const double> A_qq_e);
  void add_cell_coupling(std::span<const std::int32_t> q_dofs,
                         std::span<const std::int32_t> u_dofs, std::span<const double> A_qu_e);
  /// Closes A_gamma and B_b and takes the global lumped W from the assembled A_qq
  /// (its (theta, p) block is -M).  Throws, on every rank, std::logic_error if the
  /// cells of the two assemblies did not match on some rank, or their number
  /// changed since the first assembly (checked here, not inside the assembler's
  /// loop), and std::runtime_error if PETSc refused an insertion.
  void end(Mat A_qq);
  /// A_gamma = A + gamma sum_c B_c^T W_c^-1 B_c: the matrix begin() was given
  Mat matrix() const { return _A_gamma; }

  /// The Jacobian's displacement block as an operator (MatShell, owned here):
  /// base - gamma B_b^T W_b^-1 B_b, or under a constraint u = T x base -
  /// gamma T^T B_b^T W_b^-1 B_b T, with base A_gamma or T^T A_gamma T.  Made on the
  /// first call (after the first end()); it follows base's and B_b's values.
  Mat jacobian_block(Mat base, Mat T);

  /// rhs_u += gamma B^T W^-1 (r_q - A_qq z_q) on the p rows: the displacement
  /// rows' share of the constraint rows, for the upper block factorisation.
  /// Returns PETSc's error code (it runs inside a preconditioner's apply).
  PetscErrorCode add_constraint_rows(Vec rhs_u, Vec r_q, Vec z_q, Mat A_qu, Mat A_qq);

private:
  static PetscErrorCode multiply(Mat shell, Vec x, Vec y);
  void release_csr();

  double _gamma;
  VecHandle _w_inv;              ///< W^-1 on p rows, 0 on theta rows
  VecHandle _work;               ///< q-sized
  Mat _A_gamma = nullptr;        ///< begin()'s A, not owned
  std::vector<double> _cell_w;   ///< per cell, its p dofs' lumped mass
  std::vector<std::int32_t> _cell_q; ///< per cell, its q dofs (to check the order)
  std::size_t _next = 0;         ///< add_cell_coupling's place in _cell_w
  bool _order_broken = false;
  bool _insert_failed = false;   ///< a MatSetValues(Blocked)Local error
  std::vector<double> _K;        ///< one cell's gamma B_c^T W_c^-1 B_c
  std::vector<PetscInt> _u_dofs;
  std::vector<PetscInt> _columns; ///< one cell's u dofs, global and unblocked

  MatHandle _B;                  ///< B_b: a row per cell and node, global u columns
  PetscInt _B_start = 0;         ///< B_b's first owned row
  VecHandle _minus_d;            ///< -gamma / W_b, per row of B_b
  std::vector<PetscInt> _B_ptr, _B_cols; ///< B_b's first assembly, in CSR
  std::vector<double> _B_values;

  MatHandle _shell;
  Mat _base = nullptr, _T = nullptr; ///< jacobian_block's, not owned
  VecHandle _Bx;                   ///< B_b's rows
  VecHandle _full_x, _full_y; ///< u's full layout, under a constraint
};

} // namespace muscle
