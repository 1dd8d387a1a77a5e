#include "fem/newton/displacement_formulation.h"

#include "fem/constraints/constraint.h"
#include "fem/linear/linear_solvers.h"
#include "fem/linear/taylor_hood_split.h"
#include "fem/newton/displacement_system.h"

#include <cmath>
#include <dolfinx/la/petsc.h>
#include <limits>

using namespace dolfinx;

namespace muscle
{

DisplacementFormulation::DisplacementFormulation(DisplacementSystem& system,
                                                 const NewtonOptions& options)
    : _system(system)
{
  const LinearSolverType& type = linear_solver_type(options.linear_solver);
  if (!type.matrix)
    refuse_without_pressure(type);
  refuse_taylor_hood_split_options(false, options.linear_solver);
  const DisplacementConstraint* constraint = _system.constraint();
  _solver = type.matrix(options, {_system.problem().V(), constraint});
  _system.set_reduced_block_size(_solver->reduced_block_size());
  _x = _system.create_unknowns();
  if (constraint)
  {
    // P^T A P needs an assembled A for its symbolic phase
    _system.update_activation();
    _system.assemble_jacobian();
    _system.reduce();
  }
}

Mat DisplacementFormulation::matrix() const
{
  return _system.constraint() ? _system.reduced() : _system.A();
}

void DisplacementFormulation::start() { _system.get_unknowns(_x); }

KernelStatus DisplacementFormulation::set_state(Vec x)
{
  _system.set_unknowns(x);
  return _system.update_activation();
}

void DisplacementFormulation::residual(Vec F)
{
  _system.residual();
  _system.restrict_residual(F);
}

void DisplacementFormulation::jacobian()
{
  _system.assemble_jacobian();
  // (an overflowing tangent is reported, never reduced nor solved with)
  if (std::isfinite(_system.matrix_norm()) and _system.constraint())
    _system.reduce();
}

double DisplacementFormulation::matrix_norm() const { return _system.matrix_norm(); }

double DisplacementFormulation::convergence_floor(SNES, double xnorm) const
{
  // a residual cannot be computed more accurately than round-off in the
  // largest element forces, eps |J| |x|
  return 100 * std::numeric_limits<double>::epsilon() * _system.matrix_norm() * xnorm;
}

void DisplacementFormulation::configure_linear_solver(KSP ksp)
{
  _solver->configure(ksp);
  _solver->operator_made(_system.A(), matrix());
}

Mat DisplacementFormulation::assemble_tangent()
{
  _system.update_activation();
  _system.assemble_jacobian();
  return _system.A();
}

} // namespace muscle
