#pragma once

#include "common/petsc_handle.h"
#include "fem/newton/formulation.h"
#include "fem/newton/newton_options.h"

#include <memory>

namespace muscle
{

/// Newton on the displacement alone: u's owned dofs, or under a constraint the
/// reduced unknowns x (u = T x, the system T^T A T).  Plain elements, and F-bar
/// with theta = J0(u) inside the energy.
class DisplacementFormulation : public Formulation
{
public:
  DisplacementFormulation(DisplacementSystem& system, const NewtonOptions& options);

  Vec iterate() const override { return _x; }
  Mat matrix() const override;
  void start() override;
  KernelStatus set_state(Vec x) override;
  void residual(Vec F) override;
  void jacobian() override;
  double matrix_norm() const override;
  double convergence_floor(SNES snes, double xnorm) const override;
  void configure_linear_solver(KSP ksp) override;
  const LinearSolver& linear_solver() const override { return *_solver; }
  void start_clean() override { _solver->start_solve(); }
  Mat system_matrix() override { return matrix(); }
  Mat assemble_tangent() override;

private:
  DisplacementSystem& _system;
  std::unique_ptr<MatrixSolver> _solver;
  VecHandle _x; ///< the SNES iterate (a copy of u's owned part, or reduced)
};

} // namespace muscle
