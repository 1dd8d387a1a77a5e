// The stop message's account of a failed linear solve: the Krylov reason, and
// for multigrid the level whose smoother met a zero pivot, with the advice
// that fits (the direct solver or the shifted smoother, not a smaller step).
// The failures are built on purpose: a saddle-point matrix, whose zero
// diagonal stops SOR, and a singular one, which stops LU, alone or inside a
// field split.
#include <common/errors.h>
#include <common/petsc_options.h>
#include <fem/linear/linear_failure.h>

#include <functional>
#include <gtest/gtest.h>
#include <petscksp.h>

using namespace muscle;

namespace
{
/// The 1-D Laplacian on n unknowns, and -- saddle_point -- coupled by
/// identities to n more unknowns with zero diagonal: [[L, I], [I, 0]], like the
/// pressure block of a mixed method.
Mat tridiagonal(PetscInt n, bool saddle_point)
{
  Mat A;
  MatCreateSeqAIJ(PETSC_COMM_SELF, saddle_point ? 2 * n : n, saddle_point ? 2 * n : n, 4,
                  nullptr, &A);
  for (PetscInt i = 0; i < n; ++i)
  {
    MatSetValue(A, i, i, 2.0, INSERT_VALUES);
    if (i > 0)
      MatSetValue(A, i, i - 1, -1.0, INSERT_VALUES);
    if (i + 1 < n)
      MatSetValue(A, i, i + 1, -1.0, INSERT_VALUES);
    if (saddle_point)
    {
      MatSetValue(A, i, n + i, 1.0, INSERT_VALUES);
      MatSetValue(A, n + i, i, 1.0, INSERT_VALUES);
      MatSetValue(A, n + i, n + i, 0.0, INSERT_VALUES);
    }
  }
  MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
  return A;
}
Mat laplacian(PetscInt n) { return tridiagonal(n, false); }
Mat saddle_point(PetscInt n) { return tridiagonal(n, true); }

struct Solve
{
  std::string description;
  KSPConvergedReason reason;
  PetscErrorCode error;
};

/// Solve A x = 1 with the solver `configure` sets up; A is destroyed.
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
  MatDestroy(&A);
  return s;
}

void direct(KSP ksp, PC pc)
{
  KSPSetType(ksp, KSPPREONLY);
  PCSetType(pc, PCLU);
}
} // namespace

TEST(LinearFailure, MultigridZeroDiagonalGetsTheShiftedSmoother)
{
  // SOR smoothers (read from the options when GAMG sets up its levels)
  PetscOptionsSetValue(nullptr, "-zero_pivot_mg_levels_pc_type", "sor");
  const Solve s = solve(saddle_point(400),
                        [](KSP ksp, PC pc)
                        {
                          KSPSetOptionsPrefix(ksp, "zero_pivot_");
                          KSPSetType(ksp, KSPGMRES);
                          PCSetType(pc, PCGAMG);
                          KSPSetFromOptions(ksp);
                        });
  PetscOptionsClearValue(nullptr, "-zero_pivot_mg_levels_pc_type");
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
  const Solve s = solve(A, direct);
  ASSERT_LT(s.reason, 0);
  EXPECT_NE(s.description.find("ZEROPIVOT"), std::string::npos) << s.description;
  EXPECT_NE(linear_failure_advice(s.description).find("zero pivot"), std::string::npos);
}

TEST(LinearFailure, StalledKrylovSolverGetsLinearSolverAdvice)
{
  const Solve s = solve(laplacian(200),
                        [](KSP ksp, PC pc)
                        {
                          KSPSetType(ksp, KSPGMRES);
                          PCSetType(pc, PCJACOBI);
                          KSPSetTolerances(ksp, 1e-12, 1e-50, PETSC_DEFAULT, 2);
                        });
  ASSERT_EQ(s.reason, KSP_DIVERGED_ITS);
  EXPECT_NE(s.description.find("DIVERGED_ITS after 2 iterations"), std::string::npos)
      << s.description;
  const std::string advice = linear_failure_advice(s.description);
  EXPECT_NE(advice.find("the linear solver failed, not Newton"), std::string::npos);
  EXPECT_NE(advice.find("--linear-solver lu"), std::string::npos);
}

TEST(LinearFailure, ConvergedSolveHasNoDescription)
{
  const Solve s = solve(laplacian(50), direct);
  EXPECT_GT(s.reason, 0);
  EXPECT_TRUE(s.description.empty()) << s.description;
}

TEST(LinearFailure, FailureInsideAFieldSplitIsNamedWithItsPath)
{
  // [[0, 0], [0, L]] split into its two halves, each factored: the first half's
  // LU meets a zero pivot, two levels below the outer GMRES (the Taylor-Hood
  // split's GAMG sits there).  Its own name must reach the message, not only the
  // split's SUBPC_ERROR.
  const PetscInt n = 20;
  Mat A;
  MatCreateSeqAIJ(PETSC_COMM_SELF, 2 * n, 2 * n, 3, nullptr, &A);
  for (PetscInt i = 0; i < n; ++i)
  {
    MatSetValue(A, i, i, 0.0, INSERT_VALUES);
    MatSetValue(A, n + i, n + i, 2.0, INSERT_VALUES);
    if (i > 0)
      MatSetValue(A, n + i, n + i - 1, -1.0, INSERT_VALUES);
    if (i + 1 < n)
      MatSetValue(A, n + i, n + i + 1, -1.0, INSERT_VALUES);
  }
  MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
  PetscOptionsSetValue(nullptr, "-split_fieldsplit_u_pc_type", "lu");
  PetscOptionsSetValue(nullptr, "-split_fieldsplit_q_pc_type", "lu");
  const Solve s = solve(A,
                        [n](KSP ksp, PC pc)
                        {
                          KSPSetOptionsPrefix(ksp, "split_");
                          KSPSetType(ksp, KSPGMRES);
                          PCSetType(pc, PCFIELDSPLIT);
                          IS u, q;
                          ISCreateStride(PETSC_COMM_SELF, n, 0, 1, &u);
                          ISCreateStride(PETSC_COMM_SELF, n, n, 1, &q);
                          PCFieldSplitSetIS(pc, "u", u);
                          PCFieldSplitSetIS(pc, "q", q);
                          ISDestroy(&u);
                          ISDestroy(&q);
                          KSPSetFromOptions(ksp);
                        });
  PetscOptionsClearValue(nullptr, "-split_fieldsplit_u_pc_type");
  PetscOptionsClearValue(nullptr, "-split_fieldsplit_q_pc_type");
  ASSERT_TRUE(s.error != 0 or s.reason < 0) << "the split did not fail";
  EXPECT_NE(s.description.find("field split u (lu): FACTOR_"), std::string::npos)
      << s.description;
  EXPECT_EQ(s.description.find("field split q"), std::string::npos) << s.description;
  std::printf("%s\n", s.description.c_str());
}

TEST(LinearFailure, InnerKrylovMethodNeedsAFlexibleOuterOne)
{
  // right-preconditioned GMRES assumes a fixed preconditioner; the flexible methods
  // that precondition on the right do not
  PetscOptionsSetValue(nullptr, "-test_inner_ksp_type", "gmres");
  for (const char* outer : {"fgmres", "gcr", "pipefgmres", "fbcgs", "fbcgsr"})
  {
    PetscOptionsSetValue(nullptr, "-ksp_type", outer);
    EXPECT_NO_THROW(require_flexible_outer("-test_inner_ksp_type", "test")) << outer;
  }
  // fcg is flexible but preconditions on the left only, where the outer solve is right
  for (const char* outer : {"gmres", "bcgs", "cg", "fcg"})
  {
    PetscOptionsSetValue(nullptr, "-ksp_type", outer);
    try
    {
      require_flexible_outer("-test_inner_ksp_type", "test");
      ADD_FAILURE() << outer << " taken as flexible";
    }
    catch (const InputError& e)
    {
      const std::string message = e.what();
      EXPECT_NE(message.find("-test_inner_ksp_type gmres"), std::string::npos) << message;
      EXPECT_NE(message.find("-ksp_type fgmres"), std::string::npos) << message;
    }
  }
  PetscOptionsSetValue(nullptr, "-test_inner_ksp_type", "preonly"); // a fixed inner solve
  EXPECT_NO_THROW(require_flexible_outer("-test_inner_ksp_type", "test"));
  PetscOptionsClearValue(nullptr, "-test_inner_ksp_type");
  PetscOptionsClearValue(nullptr, "-ksp_type");
}

TEST(LinearFailure, AKrylovMethodOnOneMultigridLevelIsFoundUnderItsPrefix)
{
  // one level's own option, which a list of the block's options would miss; the
  // fixed smoothers beside it and a Krylov method under another prefix pass
  PetscOptionsSetValue(nullptr, "-test_u_mg_levels_ksp_type", "chebyshev");
  PetscOptionsSetValue(nullptr, "-other_ksp_type", "gmres");
  // Chebyshev's eigenvalue estimate runs once at set-up
  PetscOptionsSetValue(nullptr, "-test_u_mg_levels_esteig_ksp_type", "cg");
  EXPECT_NO_THROW(require_flexible_outer_under("test_", "test"));
  PetscOptionsSetValue(nullptr, "-test_u_mg_levels_3_KSP_TYPE", "gmres"); // any case
  try
  {
    require_flexible_outer_under("test_", "test");
    ADD_FAILURE() << "level 3's GMRES under the default outer GMRES";
  }
  catch (const InputError& e)
  {
    const std::string message = e.what();
    EXPECT_NE(message.find("-test_u_mg_levels_3_ksp_type gmres"), std::string::npos)
        << message;
  }
  PetscOptionsSetValue(nullptr, "-ksp_type", "fgmres");
  EXPECT_NO_THROW(require_flexible_outer_under("test_", "test"));
  for (const char* name : {"-test_u_mg_levels_ksp_type", "-test_u_mg_levels_3_ksp_type",
                           "-test_u_mg_levels_esteig_ksp_type", "-other_ksp_type", "-ksp_type"})
    PetscOptionsClearValue(nullptr, name);
}
