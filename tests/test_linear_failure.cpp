// The stop message's account of a failed linear solve: the Krylov reason, and
// for multigrid the level whose smoother met a zero pivot, with the advice
// that fits (the direct solver or the shifted smoother, not a smaller step).
// The failures are built on purpose: a saddle-point matrix, whose zero
// diagonal stops SOR, and a singular one, which stops LU.
#include <fem/linear_failure.h>

#include <functional>
#include <gtest/gtest.h>
#include <petscksp.h>

using namespace muscle;

namespace
{
/// [[L, I], [I, 0]] with L the 1-D Laplacian on n unknowns: a zero diagonal
/// in the second block, like the pressure block of a mixed method.
Mat saddle_point(PetscInt n)
{
  Mat A;
  MatCreateSeqAIJ(PETSC_COMM_SELF, 2 * n, 2 * n, 4, nullptr, &A);
  for (PetscInt i = 0; i < n; ++i)
  {
    MatSetValue(A, i, i, 2.0, INSERT_VALUES);
    if (i > 0)
      MatSetValue(A, i, i - 1, -1.0, INSERT_VALUES);
    if (i + 1 < n)
      MatSetValue(A, i, i + 1, -1.0, INSERT_VALUES);
    MatSetValue(A, i, n + i, 1.0, INSERT_VALUES);
    MatSetValue(A, n + i, i, 1.0, INSERT_VALUES);
    MatSetValue(A, n + i, n + i, 0.0, INSERT_VALUES);
  }
  MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
  return A;
}

/// The 1-D Laplacian: symmetric positive definite.
Mat laplacian(PetscInt n)
{
  Mat A;
  MatCreateSeqAIJ(PETSC_COMM_SELF, n, n, 3, nullptr, &A);
  for (PetscInt i = 0; i < n; ++i)
  {
    MatSetValue(A, i, i, 2.0, INSERT_VALUES);
    if (i > 0)
      MatSetValue(A, i, i - 1, -1.0, INSERT_VALUES);
    if (i + 1 < n)
      MatSetValue(A, i, i + 1, -1.0, INSERT_VALUES);
  }
  MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
  return A;
}

struct Solve
{
  std::string description;
  KSPConvergedReason reason;
  PetscErrorCode error;
};

Solve solve(Mat A, const std::function<void(KSP, PC)>& configure)
{
  KSP ksp;
  KSPCreate(PETSC_COMM_SELF, &ksp);
  KSPSetOperators(ksp, A, A);
  PC pc;
  KSPGetPC(ksp, &pc);
  configure(ksp, pc);
  Vec b, x;
  MatCreateVecs(A, &x, &b);
  VecSet(b, 1.0);
  // as the Newton solver does: a PETSc error fails the solve, quietly
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
  const PetscErrorCode error = KSPSolve(ksp, b, x);
  PetscPopErrorHandler();
  Solve s;
  KSPGetConvergedReason(ksp, &s.reason);
  s.error = error;
  s.description = describe_linear_failure(ksp, error);
  VecDestroy(&b);
  VecDestroy(&x);
  KSPDestroy(&ksp);
  return s;
}
} // namespace

TEST(LinearFailure, MultigridZeroPivotNamesTheLevelAndTheShiftedSmoother)
{
  Mat A = saddle_point(400);
  // SOR smoothers (read from the options when GAMG sets up its levels)
  PetscOptionsSetValue(nullptr, "-zero_pivot_mg_levels_pc_type", "sor");
  const Solve s = solve(A,
                        [](KSP ksp, PC pc)
                        {
                          KSPSetOptionsPrefix(ksp, "zero_pivot_");
                          KSPSetType(ksp, KSPGMRES);
                          PCSetType(pc, PCGAMG);
                          KSPSetFromOptions(ksp);
                        });
  PetscOptionsClearValue(nullptr, "-zero_pivot_mg_levels_pc_type");
  MatDestroy(&A);
  // PETSc 3.18's SOR stops on a zero diagonal with an error, not a reason
  ASSERT_TRUE(s.error != 0 or s.reason < 0) << "the saddle-point system did not fail";
  EXPECT_NE(s.description.find("preconditioner gamg"), std::string::npos) << s.description;
  EXPECT_NE(s.description.find("Zero diagonal"), std::string::npos) << s.description;
  const std::string advice = linear_failure_advice(s.description);
  EXPECT_NE(advice.find("zero pivot"), std::string::npos) << advice;
  EXPECT_NE(advice.find("-mg_levels_pc_sor_diagonal_shift"), std::string::npos) << advice;
  EXPECT_NE(advice.find("--linear-solver lu"), std::string::npos) << advice;
  EXPECT_EQ(advice.find("time step"), std::string::npos) << advice;
  std::printf("%s\n  -> %s\n", s.description.c_str(), advice.c_str());
}

TEST(LinearFailure, SingularFactorisationIsAZeroPivot)
{
  Mat A = laplacian(50);
  MatZeroEntries(A); // singular: every pivot is zero
  const Solve s = solve(A,
                        [](KSP ksp, PC pc)
                        {
                          KSPSetType(ksp, KSPPREONLY);
                          PCSetType(pc, PCLU);
                        });
  MatDestroy(&A);
  ASSERT_LT(s.reason, 0);
  EXPECT_NE(s.description.find("ZEROPIVOT"), std::string::npos) << s.description;
  EXPECT_NE(linear_failure_advice(s.description).find("zero pivot"), std::string::npos);
}

TEST(LinearFailure, StalledKrylovSolverGetsLinearSolverAdvice)
{
  Mat A = laplacian(200);
  const Solve s = solve(A,
                        [](KSP ksp, PC pc)
                        {
                          KSPSetType(ksp, KSPGMRES);
                          PCSetType(pc, PCJACOBI);
                          KSPSetTolerances(ksp, 1e-12, 1e-50, PETSC_DEFAULT, 2);
                        });
  MatDestroy(&A);
  ASSERT_EQ(s.reason, KSP_DIVERGED_ITS);
  EXPECT_NE(s.description.find("DIVERGED_ITS after 2 iterations"), std::string::npos)
      << s.description;
  const std::string advice = linear_failure_advice(s.description);
  EXPECT_NE(advice.find("the linear solver failed, not Newton"), std::string::npos);
  EXPECT_NE(advice.find("--linear-solver lu"), std::string::npos);
}

TEST(LinearFailure, ConvergedSolveHasNoDescription)
{
  Mat A = laplacian(50);
  const Solve s = solve(A,
                        [](KSP ksp, PC pc)
                        {
                          KSPSetType(ksp, KSPPREONLY);
                          PCSetType(pc, PCLU);
                        });
  MatDestroy(&A);
  EXPECT_GT(s.reason, 0);
  EXPECT_TRUE(s.description.empty()) << s.description;
}
