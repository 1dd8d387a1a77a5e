#pragma once

#include <petscksp.h>
#include <string>

namespace muscle
{

/// Why a linear solve failed, in words a stop message can carry: the Krylov
/// method's reason and the innermost preconditioner that failed, with the path
/// to it through field split blocks, multigrid levels and block-Jacobi/ASM
/// blocks ("gamg, multigrid level 0 coarse solve (bjacobi), block (lu):
/// FACTOR_NUMERIC_ZEROPIVOT"); or, when KSPSolve returned the PETSc error
/// `error` (SOR stops with "Zero diagonal on row N" as an error, not as a failed
/// reason), PETSc's message.  Empty when `ksp` did not fail.
std::string describe_linear_failure(KSP ksp, PetscErrorCode error = 0);

/// The message of the last PETSc error `error` (raised under
/// PetscReturnErrorHandler), without its trailing blanks.
std::string petsc_error_message(PetscErrorCode error);

/// Fails a shell preconditioner's apply so that every Krylov method sees it: the
/// reason on `pc`, Inf in `z`. A Krylov method learns of a preconditioner's
/// failure only from the norm of its output (KSPCheckNorm: DIVERGED_PC_FAILED),
/// which is how PETSc's own preconditioners report one; a zero output reads as a
/// happy breakdown, and (F)GMRES "converges" to a zero Newton direction.
void fail_shell_apply(PC pc, Vec z);

/// Clears the failure of `ksp`'s preconditioner and of those nested in it (field
/// split blocks, multigrid smoothers and coarse solves, block-Jacobi and ASM
/// blocks). PETSc 3.18's shells, PCMG and GAMG only ever set a failure, and
/// KSPSetUp then fails every later solve without applying them: a cut step must
/// start clean. `ksp` may be null.
void clear_preconditioner_failures(KSP ksp);

/// Whether an inner solve of a shell preconditioner failed. A Krylov method
/// stopped by its iteration limit (-fieldsplit_u_ksp_max_it) has still given an
/// approximation, which is what an inexact inner solve under FGMRES is for.
inline bool inner_solve_failed(KSPConvergedReason reason)
{
  return reason < 0 and reason != KSP_DIVERGED_ITS;
}

/// The advice that fits a failure described by describe_linear_failure.
std::string linear_failure_advice(const std::string& description);

} // namespace muscle
