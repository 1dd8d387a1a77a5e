#include "linear_failure.h"

namespace muscle
{
namespace
{
std::string type_of(PC pc)
{
  PCType type = nullptr;
  PCGetType(pc, &type);
  return type ? type : "none";
}

/// The first failed preconditioner below `pc` (itself, a multigrid level, a
/// block-Jacobi block), as "where: REASON"; empty if none reports a failure.
std::string failed_preconditioner(PC pc, const std::string& where)
{
  const std::string type = type_of(pc);
  if (type == PCMG or type == PCGAMG)
  {
    PetscInt levels = 0;
    PCMGGetLevels(pc, &levels);
    for (PetscInt l = 0; l < levels; ++l)
    {
      KSP smoother = nullptr;
      PCMGGetSmoother(pc, l, &smoother);
      if (!smoother)
        continue;
      PC level_pc;
      KSPGetPC(smoother, &level_pc);
      const std::string name = "multigrid level " + std::to_string(l)
                               + (l == 0 ? " (coarse solve, " : " (smoother, ")
                               + type_of(level_pc) + ")";
      if (std::string found = failed_preconditioner(level_pc, name); !found.empty())
        return found;
    }
  }
  else if (type == PCBJACOBI)
  {
    PetscInt blocks = 0, first = 0;
    KSP* sub = nullptr;
    // only after set-up; a failure before it is the block's own
    PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
    const PetscErrorCode error = PCBJacobiGetSubKSP(pc, &blocks, &first, &sub);
    PetscPopErrorHandler();
    for (PetscInt b = 0; !error and b < blocks; ++b)
    {
      PC block_pc;
      KSPGetPC(sub[b], &block_pc);
      if (std::string found = failed_preconditioner(block_pc, where + ", block "
                                                                  + type_of(block_pc));
          !found.empty())
        return found;
    }
  }
  PCFailedReason reason = PC_NOERROR;
  PCGetFailedReason(pc, &reason);
  if (reason == PC_NOERROR)
    return "";
  return where + ": " + PCFailedReasons[reason];
}
} // namespace

void clear_preconditioner_failures(KSP ksp)
{
  if (!ksp)
    return;
  PC pc;
  KSPGetPC(ksp, &pc);
  PCSetFailedReason(pc, PC_NOERROR);
  const std::string type = type_of(pc);
  // the nested solvers exist only after set-up; before it there is nothing to clear
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
  if (type == PCFIELDSPLIT)
  {
    PetscInt n = 0;
    KSP* sub = nullptr;
    if (!PCFieldSplitGetSubKSP(pc, &n, &sub))
    {
      for (PetscInt i = 0; i < n; ++i)
        clear_preconditioner_failures(sub[i]);
      PetscFree(sub);
    }
  }
  else if (type == PCMG or type == PCGAMG)
  {
    PetscInt levels = 0;
    PCMGGetLevels(pc, &levels);
    for (PetscInt l = 0; l < levels; ++l)
    {
      KSP smoother = nullptr;
      if (!PCMGGetSmoother(pc, l, &smoother))
        clear_preconditioner_failures(smoother);
      // a distinct up-smoother, if any (the same object otherwise)
      if (l > 0 and !PCMGGetSmootherUp(pc, l, &smoother))
        clear_preconditioner_failures(smoother);
    }
  }
  else if (type == PCBJACOBI or type == PCASM)
  {
    // GAMG's coarse solve is block Jacobi with LU, kept across Jacobians
    PetscInt blocks = 0, first = 0;
    KSP* sub = nullptr;
    const PetscErrorCode error = type == PCBJACOBI
                                     ? PCBJacobiGetSubKSP(pc, &blocks, &first, &sub)
                                     : PCASMGetSubKSP(pc, &blocks, &first, &sub);
    for (PetscInt b = 0; !error and b < blocks; ++b)
      clear_preconditioner_failures(sub[b]);
  }
  PetscPopErrorHandler();
}

void fail_shell_apply(PC pc, Vec z)
{
  PCSetFailedReason(pc, PC_SUBPC_ERROR);
  VecSetInf(z);
}

std::string describe_linear_failure(KSP ksp, PetscErrorCode error)
{
  KSPConvergedReason reason;
  KSPGetConvergedReason(ksp, &reason);
  if (reason >= 0 and !error)
    return "";
  KSPType type = nullptr;
  KSPGetType(ksp, &type);
  PC pc;
  KSPGetPC(ksp, &pc);
  if (error)
  {
    const char* text = nullptr;
    char* specific = nullptr;
    PetscErrorMessage(error, &text, &specific);
    std::string message = specific and *specific ? specific : (text ? text : "unknown");
    while (!message.empty() and (message.back() == '\n' or message.back() == ' '))
      message.pop_back();
    return std::string(type ? type : "ksp") + " stopped by a PETSc error, preconditioner "
           + type_of(pc) + ": " + message;
  }
  PetscInt its = 0;
  KSPGetIterationNumber(ksp, &its);
  std::string text = std::string(type ? type : "ksp") + " " + KSPConvergedReasons[reason]
                     + " after " + std::to_string(its) + " iterations, preconditioner "
                     + type_of(pc);
  if (std::string found = failed_preconditioner(pc, type_of(pc)); !found.empty())
    text += "; " + found;
  return text;
}

std::string linear_failure_advice(const std::string& d)
{
  const bool multigrid = d.find("multigrid level") != std::string::npos
                         or d.find("preconditioner gamg") != std::string::npos
                         or d.find("preconditioner mg") != std::string::npos;
  const bool pivot = d.find("ZEROPIVOT") != std::string::npos
                     or d.find("Zero diagonal") != std::string::npos;
  std::string advice = "the linear solver failed, not Newton: ";
  if (multigrid and pivot)
    // a coarse level of the nearly incompressible system can have zero
    // diagonals, where SOR and LU stop (BENCHMARKS.md, the smoother probes)
    return advice + "multigrid met a zero pivot; use the direct solver (--linear-solver lu, "
                    "scene solver.linear: lu) or the shifted smoother (-mg_levels_pc_type sor "
                    "-mg_levels_pc_sor_diagonal_shift 1e-8)";
  if (pivot)
    return advice + "the factorisation met a zero pivot (a singular system: is every rigid-body "
                    "motion held?)";
  if (multigrid)
    return advice + "multigrid did not reach the tolerance; use the direct solver "
                    "(--linear-solver lu, scene solver.linear: lu), a looser --linear-rtol, or "
                    "the shifted smoother (-mg_levels_pc_type sor "
                    "-mg_levels_pc_sor_diagonal_shift 1e-8); -ksp_monitor shows how it stalls";
  return advice + "the direct solver (--linear-solver lu, scene solver.linear: lu), a looser "
                  "--linear-rtol, or -ksp_monitor -ksp_converged_reason to see how it failed";
}

} // namespace muscle
