#pragma once

#include "common/petsc_handle.h"
#include "fem/newton/formulation.h"
#include "fem/newton/newton_options.h"

#include <dolfinx/la/Vector.h>
#include <memory>
#include <span>
#include <vector>

namespace muscle
{
class FbarCellUnknowns;
class PenaltySplit;

/// The three-field F-bar Newton: the SNES vector is [u part | cells of part 0 |
/// ...], the cell unknowns theta, p eliminated per cell (FbarCellUnknowns)
/// around a condensed displacement solve.  The condensed system K du = b is
/// solved by a matrix solver on K (T^T K T under a constraint) or by the
/// penalty split (linear: gmres-schur).
class FbarFormulation : public Formulation
{
public:
  FbarFormulation(DisplacementSystem& system, const NewtonOptions& options);
  ~FbarFormulation();

  Vec iterate() const override { return _x_ext; }
  Mat matrix() const override { return _J_ext; }
  void start() override;
  KernelStatus set_state(Vec x) override;
  void residual(Vec F) override;
  void jacobian() override;
  double matrix_norm() const override;
  double convergence_floor(SNES snes, double xnorm) const override;
  double constraint_violation() const override { return _constraint_violation; }
  bool keeps_dirichlet_rows() const override { return true; }
  void configure_linear_solver(KSP ksp) override;
  void after_options(KSP ksp) override;
  KSP linear_ksp(KSP) const override { return _inner; }
  const LinearSolver& linear_solver() const override;
  std::vector<KSP> nested() const override;
  void start_clean() override;
  long inner_iterations() const override { return _inner_iterations; }
  PetscErrorCode linear_error() const override { return _linear_error; }
  void restore() override;
  Mat system_matrix() override;
  Mat assemble_tangent() override;

  /// The penalty split, if it solves the condensed system (the tests read it).
  const PenaltySplit* penalty_split() const { return _split.get(); }

private:
  /// The u part and every part's cells of an extended vector's array.
  struct Blocks
  {
    std::span<double> u;
    std::vector<std::span<double>> cells;
  };
  Blocks blocks(double* array) const;
  /// The condensed matrix: K, or T^T K T under a constraint.
  Mat condensed() const;
  static PetscErrorCode condensed_solve(PC pc, Vec b, Vec y);
  static PetscErrorCode extended_multiply(Mat J, Vec v, Vec y);

  DisplacementSystem& _system;
  std::vector<std::unique_ptr<FbarCellUnknowns>> _cells;
  std::unique_ptr<MatrixSolver> _matrix_solver; ///< or:
  std::unique_ptr<PenaltySplit> _split;
  VecHandle _x;       ///< the displacement part: u's owned dofs, or reduced
  VecHandle _x_ext;   ///< the SNES iterate (u part, then every part's cells)
  MatHandle _J_ext;   ///< the extended Jacobian (shell)
  KSPHandle _inner;   ///< the linear solver of the condensed system
  VecHandle _rhs, _sol, _tmp; ///< displacement-part work vectors
  dolfinx::la::Vector<double> _work, _work2; ///< full displacement, with ghosts
  double _constraint_violation = 0;
  long _inner_iterations = 0;
  PetscErrorCode _linear_error = 0; ///< a PETSc error in the last condensed solve
};

} // namespace muscle
