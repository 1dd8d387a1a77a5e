#pragma once

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
class AugmentedLagrangian
{
public:
  /// gamma: the penalty in the units of the stiffness (kPa), > 0
  explicit AugmentedLagrangian(double gamma) : _gamma(gamma) {}
  ~AugmentedLagrangian();
  AugmentedLagrangian(const AugmentedLagrangian&) = delete;
  AugmentedLagrangian& operator=(const AugmentedLagrangian&) = delete;

  double gamma() const { return _gamma; }

  /// Starts A_gamma as a copy of A (local-to-global map with block size 3).
  /// Then add_cell_mass for every cell of A_qq's assembly and add_cell_coupling
  /// for every cell of A_qu's, in the same cell order, with the blocked local
  /// dofs and row-major element matrices that DOLFINx's assembler hands on
  /// (q = (theta, p) interleaved per degree-1 node, block size 2; u: 3).
  /// The same matrix object while A's nonzero pattern holds; a new pattern gives
  /// a new object that carries the old one's near-null space.
  void begin(Mat A);
  void add_cell_mass(std::span<const std::int32_t> q_dofs, std::span<const double> A_qq_e);
  void add_cell_coupling(std::span<const std::int32_t> q_dofs,
                         std::span<const std::int32_t> u_dofs, std::span<const double> A_qu_e);
  /// Closes A_gamma and takes the global lumped W from the assembled A_qq (its
  /// (theta, p) block is -M).  Throws, on every rank, std::logic_error if the
  /// cells of the two assemblies did not match on some rank (checked here, not
  /// inside the assembler's loop) and std::runtime_error if PETSc refused an
  /// insertion.
  void end(Mat A_qq);
  /// A_gamma = A + gamma sum_c B_c^T W_c^-1 B_c, owned here
  Mat matrix() const { return _A_gamma; }

  /// rhs_u += gamma B^T W^-1 (r_q - A_qq z_q) on the p rows: the displacement
  /// rows' share of the constraint rows, for the upper block factorisation.
  /// Returns PETSc's error code (it runs inside a preconditioner's apply).
  PetscErrorCode add_constraint_rows(Vec rhs_u, Vec r_q, Vec z_q, Mat A_qu, Mat A_qq);

private:
  double _gamma;
  Vec _w_inv = nullptr;          ///< W^-1 on p rows, 0 on theta rows
  Vec _work = nullptr;           ///< q-sized
  Mat _A_gamma = nullptr;
  PetscObjectState _pattern = -1; ///< A's nonzero state when _A_gamma was made
  std::vector<double> _cell_w;   ///< per cell, its p dofs' lumped mass
  std::vector<std::int32_t> _cell_q; ///< per cell, its q dofs (to check the order)
  std::size_t _next = 0;         ///< add_cell_coupling's place in _cell_w
  bool _order_broken = false;
  bool _insert_failed = false;   ///< a MatSetValuesBlockedLocal error
  std::vector<double> _K;        ///< one cell's gamma B_c^T W_c^-1 B_c
  std::vector<PetscInt> _u_dofs;
};

} // namespace muscle
