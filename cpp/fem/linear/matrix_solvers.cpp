// The solvers of an assembled displacement matrix: MUMPS, BoomerAMG, GAMG.
#include "fem/constraints/constraint.h"
#include "fem/linear/linear_solver.h"
#include "fem/linear/rigid_body_modes.h"

#include <dolfinx/fem/DofMap.h>

namespace muscle
{

void configure_gmres(KSP ksp, double rtol)
{
  KSPSetType(ksp, KSPGMRES);
  KSPSetTolerances(ksp, rtol, 1e-14, PETSC_DEFAULT, 2000);
  KSPGMRESSetRestart(ksp, gmres_restart);
}

void DirectSolver::configure(KSP ksp)
{
  KSPSetType(ksp, KSPPREONLY);
  PC pc;
  KSPGetPC(ksp, &pc);
  PCSetType(pc, PCLU);
  PCFactorSetMatSolverType(pc, MATSOLVERMUMPS);
}

AmgSolver::AmgSolver(Type type, const LinearSettings& settings, DisplacementSpace space)
    : _type(type), _settings(settings), _space(std::move(space))
{
  if (_type == Type::gamg)
    *_modes.out() = rigid_body_modes(*_space.V, _space.constraint,
                                     _settings.near_null_space == "bodies");
}

int AmgSolver::reduced_block_size() const
{
  return _type == Type::gamg and _settings.reduced_blocks and _space.constraint
                 and _space.constraint->keeps_whole_nodes()
             ? _space.V->dofmap()->index_map_bs()
             : 1;
}

void AmgSolver::configure(KSP ksp)
{
  configure_gmres(ksp, _settings.linear_rtol);
  PC pc;
  KSPGetPC(ksp, &pc);
  if (_type == Type::hypre)
  {
    PCSetType(pc, PCHYPRE);
    PCHYPRESetType(pc, "boomeramg");
  }
  else
    PCSetType(pc, PCGAMG);
}

void AmgSolver::operator_made(Mat full, Mat op)
{
  if (_type != Type::gamg)
    return;
  MatSetNearNullSpace(op, _modes);
  MatSetBlockSize(full, 3);
}

} // namespace muscle
