#pragma once

#include "common/petsc_handle.h"
#include "fem/newton/formulation.h"
#include "fem/newton/newton_options.h"

#include <array>
#include <dolfinx/la/Vector.h>
#include <memory>
#include <vector>

namespace muscle
{
class TaylorHoodSplit;

/// Taylor-Hood Newton: the SNES vector is [u owned | q owned] with q = (theta,
/// p) the degree-1 field of the mixed element, the Jacobian the nest of the
/// displacement block (everything the displacement Newton assembles: loads,
/// contact, Dirichlet rows) and the three blocks of q.  Under a linear
/// constraint u = T x the displacement part is x: the blocks T^T A T, T^T A_uq
/// and A_qu T.  Solved by MUMPS on the nest assembled into one matrix, or by
/// the Schur split on the nest itself (TaylorHoodSplit).
class TaylorHoodFormulation : public Formulation
{
public:
  TaylorHoodFormulation(DisplacementSystem& system, const NewtonOptions& options);
  ~TaylorHoodFormulation();

  Vec iterate() const override { return _x_ext; }
  Mat matrix() const override;
  void start() override;
  KernelStatus set_state(Vec x) override;
  void residual(Vec F) override;
  void jacobian() override;
  double matrix_norm() const override;
  double convergence_floor(SNES snes, double xnorm) const override;
  void configure_linear_solver(KSP ksp) override;
  const LinearSolver& linear_solver() const override;
  void start_clean() override;
  void converged() override;
  void restore() override;
  Mat system_matrix() override;
  Mat assemble_tangent() override;

private:
  /// T^T A_uq and A_qu T (with the augmented Lagrangian T^T A T is T^T A_gamma T)
  void reduce_coupling_blocks(bool first);

  DisplacementSystem& _system;
  std::unique_ptr<MatrixSolver> _direct; ///< MUMPS on the assembled copy, or:
  std::unique_ptr<TaylorHoodSplit> _split;
  VecHandle _x;       ///< the displacement part: u's owned dofs, or reduced
  VecHandle _x_ext;   ///< the SNES iterate [u | q]
  VecHandle _tmp;     ///< displacement-part work vector
  std::unique_ptr<dolfinx::la::Vector<double>> _bq; ///< q residual, with ghosts
  std::array<MatHandle, 3> _blocks;   ///< dR_u/dq, dR_q/du, dR_q/dq
  std::array<MatHandle, 2> _reduced;  ///< T^T A_uq, A_qu T under a constraint
  /// [[A, A_uq], [A_qu, A_qq]]; A an operator under the augmented Lagrangian
  MatHandle _J_nest;
  MatHandle _J_mixed; ///< the nest assembled (MUMPS only; GMRES takes the nest)
  PetscObjectState _mixed_state = -1; ///< A's nonzero state when _J_mixed was made
  double _mixed_norm = 0; ///< infinity norm of the mixed Jacobian (the nest's rows)
  std::vector<double> _q_converged; ///< q of the last converged solve (owned)
};

} // namespace muscle
