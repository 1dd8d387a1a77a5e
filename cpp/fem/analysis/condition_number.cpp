#include "fem/analysis/condition_number.h"
#include "fem/analysis/eigenfrequencies.h"

#include <cmath>
#include <slepceps.h>
#include <vector>

namespace muscle
{
namespace
{
/// Owned rows that are not a lone unit diagonal (global numbering).
IS free_rows(Mat A)
{
  PetscInt begin, end;
  MatGetOwnershipRange(A, &begin, &end);
  std::vector<PetscInt> rows;
  for (PetscInt r = begin; r < end; ++r)
  {
    PetscInt ncols;
    const PetscInt* cols;
    const PetscScalar* vals;
    MatGetRow(A, r, &ncols, &cols, &vals);
    int nonzero = 0;
    bool unit_diagonal = false;
    for (PetscInt k = 0; k < ncols; ++k)
    {
      if (vals[k] != 0.0)
        ++nonzero;
      if (cols[k] == r and vals[k] == 1.0)
        unit_diagonal = true;
    }
    MatRestoreRow(A, r, &ncols, &cols, &vals);
    if (!(nonzero == 1 and unit_diagonal))
      rows.push_back(r);
  }
  IS is;
  ISCreateGeneral(PetscObjectComm((PetscObject)A), rows.size(), rows.data(),
                  PETSC_COPY_VALUES, &is);
  return is;
}

double extreme_eigenvalue(Mat K, bool largest)
{
  EPS eps;
  EPSCreate(PetscObjectComm((PetscObject)K), &eps);
  EPSSetOperators(eps, K, nullptr);
  EPSSetProblemType(eps, EPS_HEP);
  EPSSetDimensions(eps, 1, PETSC_DEFAULT, PETSC_DEFAULT);
  EPSSetTolerances(eps, 1e-6, 500);
  if (largest)
    EPSSetWhichEigenpairs(eps, EPS_LARGEST_MAGNITUDE);
  else
    nearest_zero(eps);
  EPSSetOptionsPrefix(eps, "condition_");
  EPSSetFromOptions(eps);
  double value = 0;
  if (EPSSolve(eps) == 0)
  {
    PetscInt nconv = 0;
    EPSGetConverged(eps, &nconv);
    if (nconv > 0)
    {
      PetscScalar re, im;
      EPSGetEigenvalue(eps, 0, &re, &im);
      value = std::abs(re);
    }
  }
  EPSDestroy(&eps);
  return value;
}
} // namespace

ConditionEstimate estimate_condition_number(Mat A)
{
  initialise_slepc();
  IS rows = free_rows(A);
  Mat K;
  MatCreateSubMatrix(A, rows, rows, MAT_INITIAL_MATRIX, &K);
  ISDestroy(&rows);
  ConditionEstimate e;
  e.lambda_max = extreme_eigenvalue(K, true);
  e.lambda_min = extreme_eigenvalue(K, false);
  if (e.lambda_min > 0)
    e.condition = e.lambda_max / e.lambda_min;
  MatDestroy(&K);
  return e;
}

} // namespace muscle
