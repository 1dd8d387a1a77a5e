#pragma once

#include <petscmat.h>

namespace muscle
{

/// Extreme eigenvalues of a symmetric system matrix and their ratio.
struct ConditionEstimate
{
  double lambda_max = 0; ///< largest |eigenvalue|
  double lambda_min = 0; ///< smallest |eigenvalue|
  double condition = 0;  ///< lambda_max / lambda_min (0 if not converged)
};

/// Condition number k(A) = |ev_max / ev_min| of the stiffness on the free
/// unknowns (the paper's measure, section "Influence of the incompressibility").
/// Rows that hold a Dirichlet condition (a lone unit diagonal) are removed
/// first: their eigenvalue 1 says nothing about the discretisation.  SLEPc:
/// Krylov-Schur for the largest, shift-and-invert at 0 (MUMPS) for the smallest.
ConditionEstimate estimate_condition_number(Mat A);

} // namespace muscle
