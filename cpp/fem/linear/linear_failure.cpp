#include "fem/linear/linear_failure.h"

#include <utility>
#include <vector>

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

/// A field split block's name from its solver's option prefix
/// ("fieldsplit_u_" -> "u").
std::string split_name(KSP ksp, PetscInt i)
{
  const char* prefix = nullptr;
  KSPGetOptionsPrefix(ksp, &prefix);
  std::string name = prefix ? prefix : "";
  if (const std::size_t at = name.rfind("fieldsplit_"); at != std::string::npos)
    name = name.substr(at + 11);
  if (!name.empty() and name.back() == '_')
    name.pop_back();
  return name.empty() ? std::to_string(i) : name;
}

/// The solvers nested directly in `pc` (field split blocks, multigrid smoothers
/// and coarse solves, block-Jacobi and ASM blocks), each with where it sits.
/// They exist only after set-up: before it, none.
std::vector<std::pair<KSP, std::string>> nested_solvers(PC pc, const std::string& where)
{
  std::vector<std::pair<KSP, std::string>> nested;
  const std::string type = type_of(pc);
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
  if (type == PCFIELDSPLIT)
  {
    PetscInt n = 0;
    KSP* sub = nullptr;
    if (!PCFieldSplitGetSubKSP(pc, &n, &sub))
    {
      for (PetscInt i = 0; i < n; ++i)
        nested.emplace_back(sub[i], where + ", field split " + split_name(sub[i], i));
      PetscFree(sub);
    }
  }
  else if (type == PCMG or type == PCGAMG)
  {
    PetscInt levels = 0;
    PCMGGetLevels(pc, &levels);
    for (PetscInt l = 0; l < levels; ++l)
    {
      const std::string level = where + ", multigrid level " + std::to_string(l);
      // not PCMGGetSmootherUp: it would make a distinct up-smoother (without
      // vertex stars, and with its own eigenvalue estimate); none is made here
      KSP smoother = nullptr;
      if (!PCMGGetSmoother(pc, l, &smoother) and smoother)
        nested.emplace_back(smoother, level + (l == 0 ? " coarse solve" : " smoother"));
    }
  }
  else if (type == PCBJACOBI or type == PCASM)
  {
    // GAMG's coarse solve is block Jacobi with LU, kept across Jacobians.  No
    // first-block number: asking for it is an MPI_Scan, and this walk runs on a
    // failing rank alone (describe_linear_failure)
    PetscInt blocks = 0;
    KSP* sub = nullptr;
    const PetscErrorCode error = type == PCBJACOBI
                                     ? PCBJacobiGetSubKSP(pc, &blocks, nullptr, &sub)
                                     : PCASMGetSubKSP(pc, &blocks, nullptr, &sub);
    // PCASM hands out its block count before set-up, but no solvers yet
    for (PetscInt b = 0; !error and sub and b < blocks; ++b)
      nested.emplace_back(sub[b], where + ", block");
  }
  PetscPopErrorHandler();
  return nested;
}

/// The first failed preconditioner in or below `pc`, innermost first, as
/// "where (type): REASON"; empty if none reports a failure.
std::string failed_preconditioner(PC pc, const std::string& where)
{
  for (const auto& [ksp, name] : nested_solvers(pc, where))
  {
    PC sub;
    KSPGetPC(ksp, &sub);
    if (std::string found = failed_preconditioner(sub, name + " (" + type_of(sub) + ")");
        !found.empty())
      return found;
  }
  PCFailedReason reason = PC_NOERROR;
  PCGetFailedReason(pc, &reason);
  if (reason == PC_NOERROR)
    return "";
  return where + ": " + PCFailedReasons[reason];
}
} // namespace

std::string petsc_error_message(PetscErrorCode error)
{
  const char* text = nullptr;
  char* specific = nullptr;
  PetscErrorMessage(error, &text, &specific);
  std::string message = specific and *specific ? specific : (text ? text : "unknown");
  while (!message.empty() and (message.back() == '\n' or message.back() == ' '))
    message.pop_back();
  return message;
}

void clear_preconditioner_failures(KSP ksp)
{
  if (!ksp)
    return;
  PC pc;
  KSPGetPC(ksp, &pc);
  PCSetFailedReason(pc, PC_NOERROR);
  for (const auto& nested : nested_solvers(pc, ""))
    clear_preconditioner_failures(nested.first);
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
    return std::string(type ? type : "ksp") + " stopped by a PETSc error, preconditioner "
           + type_of(pc) + ": " + petsc_error_message(error);
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
  if (pivot and d.find("(stars)") != std::string::npos)
    return advice + "a vertex star's block is singular; relax p-multigrid's degree-2 level "
                    "with Jacobi (without -fieldsplit_u_mg_levels_pc_type stars) or use the "
                    "direct solver (--linear-solver lu, scene solver.linear: lu)";
  if (multigrid and pivot)
    // a coarse level of the nearly incompressible system can have zero
    // diagonals, where SOR and LU stop (BENCHMARKS.md, "Multigrid smoothers at the preset kappa (by hand)")
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
