#pragma once

#include "fem/linear/linear_solver.h"

#include <dolfinx/la/Vector.h>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace muscle
{
class FbarCellUnknowns;

/// linear: gmres-schur on F-bar's three-field Newton: the condensed system
/// K du = b solved through its saddle form (the theory at the top of
/// penalty_split.cpp).  It works on the cells' linearisation and the
/// condensed tangent A (full layout) that the formulation assembles.
class PenaltySplit : public LinearSolver
{
public:
  /// `cells`: every part's cell unknowns; `A`: the condensed tangent in the full
  /// layout (its values change with each Jacobian, the object stays); `layout`:
  /// a vector of the unknowns Newton solves for (u's owned dofs or the reduced x).
  PenaltySplit(const LinearSettings& settings, DisplacementSpace space,
               const std::vector<std::unique_ptr<FbarCellUnknowns>>& cells, Mat A, Vec layout);
  ~PenaltySplit();
  PenaltySplit(const PenaltySplit&) = delete;
  PenaltySplit& operator=(const PenaltySplit&) = delete;

  /// GMRES on the saddle form with the block factorisation as its preconditioner.
  void configure(KSP ksp);
  /// The soft matrix, its multigrid and the Schur weights from the Jacobian in A.
  void update();
  /// sol from rhs (the condensed system's layout): (PETSc's error, Krylov iterations).
  std::pair<PetscErrorCode, PetscInt> solve(Vec rhs, Vec sol);
  std::vector<KSP> nested() const override { return {_soft, _schur}; }

  // what the tests check
  /// q <- S^-1 q, approximately, with the sparse Schur complement
  /// (-penalty_split_schur sparse); false if its solve failed.
  bool sparse_schur_solve(PetscScalar* q);
  /// Per part and cell, the penalty share (1 - s_c) K00_c taken out of the soft matrix.
  const std::vector<std::vector<double>>& removed_shares() const { return _split; }
  Mat soft_matrix() const { return _A_soft; }
  const std::vector<std::unique_ptr<FbarCellUnknowns>>& cells() const { return _cells; }

private:
  static PetscErrorCode saddle_multiply(Mat M, Vec v, Vec y);
  static PetscErrorCode apply(PC pc, Vec r, Vec z);
  /// _schur_factor and _schur_sym from the split and d = diag(A_s) (full layout, ghosts)
  void update_sparse_schur(std::span<const double> d);

  LinearSettings _settings;
  DisplacementSpace _space;
  const std::vector<std::unique_ptr<FbarCellUnknowns>>& _cells;
  Mat _A; ///< not owned
  KSP _ksp = nullptr; ///< the KSP configure() set up (not owned)
  dolfinx::la::Vector<double> _work, _work2; ///< full displacement, with ghosts
  NullSpaceHandle _modes;
  MatHandle _saddle;   ///< (du, q) -> (A_s du + B^T q, D_r B du - q), shell
  VecHandle _saddle_b, _saddle_x;
  VecHandle _part_in, _part_out; ///< the du part of saddle vectors (no own array)
  KSPHandle _soft;     ///< one V-cycle on the soft matrix
  MatHandle _A_soft;   ///< K with the cells' stiff penalty share taken out
  MatHandle _A_soft_red; ///< T^T A_soft T when constrained
  PetscObjectState _soft_state = -1; ///< A's nonzero state when _A_soft was made
  VecHandle _soft_r;
  /// per part and cell: the removed penalty (1 - s_c) K00_c, and sum_j g_j^2 / A_s,jj
  std::vector<std::vector<double>> _split, _schur_h;
  PetscReal _split_ratio = 1; ///< kept penalty / rest of the diagonal (-penalty_split_ratio)
  /// the block factorisation applied (-penalty_split_factorization): "lower" or "upper"
  /// (one V-cycle per Krylov iteration), "full" (two)
  std::string _split_factorization = "lower";
  /// the Schur complement's approximation (-penalty_split_schur): "diagonal", the cells'
  /// diagonal of I + D_r B diag(A_s)^-1 B^T, or "sparse", that matrix itself
  std::string _split_schur = "diagonal";
  MatHandle _schur_factor; ///< C = D_r^1/2 B diag(A_s)^-1/2, cells x full layout
  MatHandle _schur_sym;    ///< I + C C^T
  KSPHandle _schur;        ///< one V-cycle on _schur_sym (-schur_ options)
  VecHandle _schur_rhs, _schur_w;
  /// diag(A_s), full layout with ghosts: kept for the Schur solves
  std::vector<double> _soft_diagonal;
};

} // namespace muscle
