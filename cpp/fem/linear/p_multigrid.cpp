#include "fem/linear/p_multigrid.h"

#include "common/errors.h"
#include "common/petsc_options.h"
#include "fem/linear/linear_failure.h"
#include "fem/linear/rigid_body_modes.h"

#include <basix/finite-element.h>
#include <dolfinx/fem/DofMap.h>
#include <dolfinx/fem/interpolate.h> // discreteoperators.h uses its impl:: without including it
#include <dolfinx/fem/discreteoperators.h>
#include <dolfinx/fem/sparsitybuild.h>
#include <dolfinx/fem/utils.h>
#include <dolfinx/la/SparsityPattern.h>
#include <dolfinx/la/petsc.h>
#include <dolfinx/mesh/Mesh.h>
#include <dolfinx/mesh/cell_types.h>
#include <cstdlib>
#include <numeric>
#include <vector>

using namespace dolfinx;

namespace muscle
{

namespace
{
/// -fieldsplit_u_mg_coarse_lag: Newton iterations per Galerkin product, 1 if not given
PetscInt lag_option()
{
  const char* name = "-fieldsplit_u_mg_coarse_lag";
  PetscBool given;
  PetscOptionsHasName(nullptr, nullptr, name, &given);
  if (!given)
    return 1;
  const std::string text = string_option(name);
  char* end;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() or *end != '\0' or value < 1 or value > 1000000)
    throw InputError(std::string(name) + " '" + text
                     + "': must be an integer from 1 to 1000000 (1: P^T A P at every "
                       "Newton iteration)");
  return value;
}

/// P's rows with their exact zeros left out.  The interpolation writes every pair of
/// a cell's degree-2 nodes and degree-1 vertices, but a vertex's hat function is
/// zero at the nodes on its star's outer faces: 64 of a hexahedron's 216 pairs are
/// not zero.  Kept, those zeros make P^T A P's pattern reach two cells away instead
/// of one, far wider than the degree-1 stencil, and the AMG below coarsens that
/// pattern (BENCHMARKS.md, "Preconditioners against kappa").  Collective.
Mat without_exact_zeros(Mat P)
{
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(P));
  PetscInt m, n, M, N, row_begin, row_end, col_begin, col_end, row_bs, col_bs;
  MatGetLocalSize(P, &m, &n);
  MatGetSize(P, &M, &N);
  MatGetOwnershipRange(P, &row_begin, &row_end);
  MatGetOwnershipRangeColumn(P, &col_begin, &col_end);
  MatGetBlockSizes(P, &row_bs, &col_bs);
  std::vector<PetscInt> diagonal(m, 0), off_diagonal(m, 0);
  for (PetscInt row = row_begin; row < row_end; ++row)
  {
    PetscInt count;
    const PetscInt* cols;
    const PetscScalar* values;
    MatGetRow(P, row, &count, &cols, &values);
    for (PetscInt k = 0; k < count; ++k)
      if (values[k] != 0.0)
        ++(cols[k] >= col_begin and cols[k] < col_end ? diagonal : off_diagonal)[row - row_begin];
    MatRestoreRow(P, row, &count, &cols, &values);
  }
  Mat compact;
  MatCreate(comm, &compact);
  MatSetSizes(compact, m, n, M, N);
  MatSetBlockSizes(compact, row_bs, col_bs);
  MatSetType(compact, MATAIJ);
  MatSeqAIJSetPreallocation(compact, 0, diagonal.data());
  MatMPIAIJSetPreallocation(compact, 0, diagonal.data(), 0, off_diagonal.data());
  MatSetOption(compact, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE);
  std::vector<PetscInt> kept_cols;
  std::vector<PetscScalar> kept_values;
  for (PetscInt row = row_begin; row < row_end; ++row)
  {
    PetscInt count;
    const PetscInt* cols;
    const PetscScalar* values;
    MatGetRow(P, row, &count, &cols, &values);
    kept_cols.clear();
    kept_values.clear();
    for (PetscInt k = 0; k < count; ++k)
      if (values[k] != 0.0)
      {
        kept_cols.push_back(cols[k]);
        kept_values.push_back(values[k]);
      }
    MatRestoreRow(P, row, &count, &cols, &values);
    MatSetValues(compact, 1, &row, kept_cols.size(), kept_cols.data(), kept_values.data(),
                 INSERT_VALUES);
  }
  MatAssemblyBegin(compact, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(compact, MAT_FINAL_ASSEMBLY);
  return compact;
}
} // namespace

DegreeOneCoarsening::DegreeOneCoarsening(std::shared_ptr<const fem::FunctionSpace> V,
                                         std::span<const std::int32_t> dirichlet_dofs)
    : _lag(lag_option())
{
  auto mesh = V->mesh();
  const int bs = V->dofmap()->index_map_bs();
  if (V->element()->basix_element().degree() != 2 or bs != 3)
    throw InputError("p-multigrid on the displacement block: needs a degree-2 vector "
                     "displacement space (Taylor-Hood elements)");
  const basix::FiniteElement e1 = basix::create_element(
      basix::element::family::P, mesh::cell_type_to_basix_type(mesh->topology().cell_type()),
      1, basix::element::lagrange_variant::gll_warped, false);
  _V1 = std::make_shared<fem::FunctionSpace>(
      fem::create_functionspace(std::const_pointer_cast<mesh::Mesh>(mesh), e1, bs));

  const int tdim = mesh->topology().dim();
  auto cell_map = mesh->topology().index_map(tdim);
  std::vector<std::int32_t> cells(cell_map->size_local());
  std::iota(cells.begin(), cells.end(), 0);
  la::SparsityPattern pattern(mesh->comm(), {V->dofmap()->index_map, _V1->dofmap()->index_map},
                              {bs, bs});
  fem::sparsitybuild::cells(pattern, cells, {*V->dofmap(), *_V1->dofmap()});
  pattern.assemble();
  *_P.out() = la::petsc::create_matrix(mesh->comm(), pattern);
  MatSetOption(_P, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE);
  // a node shared by cells gets the same value from each: insert, not add
  fem::interpolation_matrix<PetscScalar>(*_V1, *V,
                                         la::petsc::Matrix::set_block_fn(_P, INSERT_VALUES));
  MatAssemblyBegin(_P, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_P, MAT_FINAL_ASSEMBLY);
  std::vector<PetscInt> rows(dirichlet_dofs.begin(), dirichlet_dofs.end());
  MatZeroRowsLocal(_P, rows.size(), rows.data(), 0.0, nullptr, nullptr);
  _P = MatHandle(without_exact_zeros(_P));
  *_modes.out() = rigid_body_modes(*_V1, nullptr, false);
}

void DegreeOneCoarsening::restrict_rows(Mat R)
{
  MatHandle RP;
  MatMatMult(R, _P, MAT_INITIAL_MATRIX, PETSC_DEFAULT, RP.out());
  _P = std::move(RP);
  _coarse.reset(); // a product of the old P
}

Mat DegreeOneCoarsening::coarse_matrix(Mat A)
{
  prepare(A);
  if (++_calls_since < _lag)
    return _coarse;
  _calls_since = 0;
  MatPtAP(A, _P, MAT_REUSE_MATRIX, PETSC_DEFAULT, _coarse.address());
  return _coarse;
}

void DegreeOneCoarsening::prepare(Mat A)
{
  PetscObjectState pattern;
  MatGetNonzeroState(A, &pattern);
  PetscObjectId id;
  PetscObjectGetId(reinterpret_cast<PetscObject>(A), &id);
  if (_coarse and pattern == _pattern and id == _operator)
    return;
  MatProductCreate(A, _P, nullptr, _coarse.out());
  MatProductSetType(_coarse, MATPRODUCT_PtAP);
  // on one rank, P^T (A P) formed as R A P with R = P^T explicit, faster than
  // PETSc's default on the fusiform;
  // on several ranks the parallel default is the fastest tried
  int ranks;
  MPI_Comm_size(PetscObjectComm(reinterpret_cast<PetscObject>(A)), &ranks);
  if (ranks == 1)
    MatProductSetAlgorithm(_coarse, "rap");
  // -fieldsplit_u_mg_coarse_mat_product_algorithm chooses another (not -matptap_via,
  // which PETSc reads for MatPtAP's products only)
  MatSetOptionsPrefix(_coarse, "fieldsplit_u_mg_coarse_");
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
  const PetscErrorCode error = MatProductSetFromOptions(_coarse);
  PetscPopErrorHandler();
  if (error)
    throw InputError("p-multigrid's Galerkin product P^T A P: " + petsc_error_message(error));
  MatProductSymbolic(_coarse);
  MatSetNearNullSpace(_coarse, _modes);
  _calls_since = _lag - 1; // values at the next call
  _pattern = pattern;
  _operator = id;
}

} // namespace muscle
