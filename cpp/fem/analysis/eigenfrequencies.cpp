#include "fem/analysis/eigenfrequencies.h"

#include "fem/constraints/constraint.h"

#include <algorithm>
#include <cmath>

namespace muscle
{
namespace
{
/// The rows with mass (the free dofs: a fixed dof's mass row is empty).
IS rows_with_mass(Mat M)
{
  Vec d;
  MatCreateVecs(M, &d, nullptr);
  MatGetDiagonal(M, d);
  PetscInt begin, end;
  VecGetOwnershipRange(d, &begin, &end);
  const PetscScalar* values;
  VecGetArrayRead(d, &values);
  std::vector<PetscInt> rows;
  for (PetscInt i = begin; i < end; ++i)
    if (values[i - begin] > 0)
      rows.push_back(i);
  VecRestoreArrayRead(d, &values);
  VecDestroy(&d);
  IS is;
  ISCreateGeneral(PetscObjectComm((PetscObject)M), rows.size(), rows.data(), PETSC_COPY_VALUES,
                  &is);
  return is;
}
} // namespace

void initialise_slepc()
{
  PetscBool initialised = PETSC_FALSE;
  SlepcInitialized(&initialised);
  if (!initialised)
    SlepcInitialize(nullptr, nullptr, nullptr, nullptr);
}

void nearest_zero(EPS eps)
{
  EPSSetWhichEigenpairs(eps, EPS_TARGET_MAGNITUDE);
  EPSSetTarget(eps, 0.0);
  ST st;
  EPSGetST(eps, &st);
  STSetType(st, STSINVERT);
  KSP ksp;
  STGetKSP(st, &ksp);
  KSPSetType(ksp, KSPPREONLY);
  PC pc;
  KSPGetPC(ksp, &pc);
  PCSetType(pc, PCLU);
  PCFactorSetMatSolverType(pc, MATSOLVERMUMPS);
}

std::vector<double> natural_frequencies(Mat K_full, Mat M_full,
                                        const DisplacementConstraint* constraint, int count)
{
  initialise_slepc();
  Mat K_red = nullptr, M_red = nullptr;
  if (constraint)
  {
    MatPtAP(K_full, constraint->T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, &K_red);
    MatPtAP(M_full, constraint->T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, &M_red);
  }
  Mat K_all = constraint ? K_red : K_full, M_all = constraint ? M_red : M_full;
  IS rows = rows_with_mass(M_all);
  Mat K, M;
  MatCreateSubMatrix(K_all, rows, rows, MAT_INITIAL_MATRIX, &K);
  MatCreateSubMatrix(M_all, rows, rows, MAT_INITIAL_MATRIX, &M);
  ISDestroy(&rows);
  MatDestroy(&K_red);
  MatDestroy(&M_red);

  EPS eps;
  EPSCreate(PetscObjectComm((PetscObject)K), &eps);
  EPSSetOperators(eps, K, M);
  EPSSetProblemType(eps, EPS_GHEP);
  EPSSetDimensions(eps, count, PETSC_DEFAULT, PETSC_DEFAULT);
  EPSSetTolerances(eps, 1e-10, 500);
  nearest_zero(eps);
  EPSSetOptionsPrefix(eps, "modes_");
  EPSSetFromOptions(eps);
  std::vector<double> omega;
  if (EPSSolve(eps) == 0)
  {
    PetscInt converged = 0;
    EPSGetConverged(eps, &converged);
    for (PetscInt i = 0; i < std::min<PetscInt>(converged, count); ++i)
    {
      PetscScalar re, im;
      EPSGetEigenvalue(eps, i, &re, &im);
      // a negative eigenvalue (an unstable state) comes back as a negative omega
      omega.push_back(re >= 0 ? std::sqrt(re) : -std::sqrt(-re));
    }
  }
  EPSDestroy(&eps);
  MatDestroy(&K);
  MatDestroy(&M);
  std::sort(omega.begin(), omega.end());
  return omega;
}

} // namespace muscle
