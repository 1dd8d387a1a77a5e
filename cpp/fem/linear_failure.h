#pragma once

#include <petscksp.h>
#include <string>

namespace muscle
{

/// Why a linear solve failed, in words a stop message can carry: the Krylov
/// method's reason and, for multigrid, the level whose smoother or coarse solve
/// failed and how ("multigrid level 0 (coarse): FACTOR_NUMERIC_ZEROPIVOT");
/// or, when KSPSolve returned the PETSc error `error` (SOR stops with "Zero
/// diagonal on row N" as an error, not as a failed reason), PETSc's message.
/// Empty when `ksp` did not fail.
std::string describe_linear_failure(KSP ksp, PetscErrorCode error = 0);

/// The advice that fits a failure described by describe_linear_failure.
std::string linear_failure_advice(const std::string& description);

} // namespace muscle
