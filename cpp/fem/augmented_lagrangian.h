#pragma once

#include <petscmat.h>

namespace muscle
{

/// The augmented-Lagrangian form of the Taylor-Hood system for its block
/// preconditioner: gamma B^T W^-1 times the constraint rows (p: the L2
/// projection of J onto theta) added to the displacement rows, so that the
/// displacement block A_gamma = A + gamma B^T W^-1 B regains the bulk stiffness
/// that holding theta takes out of A.  B: the p rows of dR_q/du; W: the degree-1
/// mass matrix lumped (the p column sums of A_qq's theta rows, which are -M), so
/// B^T W^-1 B stays sparse.  The system solved is unchanged (GMRES sees the
/// Jacobian); only the preconditioner's blocks are. Under activation A is
/// indefinite (negative eigenvalues, dilational fields the fibre stress
/// lowers the energy of): gamma lifts them, and the Schur complement of q
/// becomes close to its approximation for any mesh when the displacement
/// block is solved well (BENCHMARKS.md, "Preconditioners against kappa").
class AugmentedLagrangian
{
public:
  /// gamma: the penalty in the units of the stiffness (kPa), > 0
  explicit AugmentedLagrangian(double gamma) : _gamma(gamma) {}
  ~AugmentedLagrangian();
  AugmentedLagrangian(const AugmentedLagrangian&) = delete;
  AugmentedLagrangian& operator=(const AugmentedLagrangian&) = delete;

  double gamma() const { return _gamma; }
  /// A_gamma from the current blocks, in place after the first call (a new
  /// nonzero pattern of A, from contact, makes it anew).  Owned here.
  /// A_qu, A_qq: dR_q/du and dR_q/dq, rows (theta, p) interleaved per node.
  Mat update(Mat A, Mat A_qu, Mat A_qq);
  Mat matrix() const { return _A_gamma; }
  /// rhs_u += gamma B^T W^-1 (r_q - A_qq z_q) on the p rows: the displacement
  /// rows' share of the constraint rows, for the upper block factorisation
  void add_constraint_rows(Vec rhs_u, Vec r_q, Vec z_q, Mat A_qu, Mat A_qq);

private:
  double _gamma;
  Vec _w_inv = nullptr;        ///< W^-1 on p rows, 0 on theta rows
  Vec _work = nullptr;         ///< q-sized
  Mat _scaled_coupling = nullptr; ///< W^-1 A_qu
  Mat _grad_div = nullptr;     ///< B^T W^-1 B
  Mat _A_gamma = nullptr;
  PetscObjectState _pattern = -1; ///< A's nonzero state when _A_gamma was made
};

} // namespace muscle
