#include "fem/linear/star_relaxation.h"

#include <Eigen/Dense>
#include <algorithm>
#include <limits>
#include <new>
#include <stdexcept>
#include <petsc/private/pcimpl.h> // a new PC type sets its operations (PETSc's way)
#include <vector>

namespace muscle
{
namespace
{
struct Stars
{
  bool given = false;
  std::vector<PetscInt> offsets{0}; ///< patch p: positions[offsets[p] .. offsets[p + 1])
  std::vector<PetscInt> positions;  ///< into `rows`, the union of the patches' rows
  std::vector<PetscInt> rows;       ///< global, sorted
  VecScatter scatter = nullptr;     ///< the operator's vector -> `in` (rows)
  Vec in = nullptr, out = nullptr;
  /// A_p^-1, column-major, one after another: in double or, if `single`, rounded
  std::vector<double> inverses;
  std::vector<float> inverses_single;
  bool single = true; ///< not -pc_stars_double: relax in single precision
  PetscInt largest = 0;
  long total_patches = 0, total_largest = 0; ///< over all ranks, for the view
  PetscInt local_rows = -1;                   ///< the operator's, when `scatter` was made
};

/// -log_view's rows for the stars' factorisation and relaxation
PetscLogEvent factor_event = 0, relax_event = 0;

Stars& stars_of(PC pc) { return *static_cast<Stars*>(pc->data); }

PetscErrorCode reset(Stars& s)
{
  PetscFunctionBeginUser;
  PetscCall(VecScatterDestroy(&s.scatter));
  PetscCall(VecDestroy(&s.in));
  PetscCall(VecDestroy(&s.out));
  PetscFunctionReturn(0);
}

/// The scatter of the patches' rows, owned or not, into one local vector: made
/// once, and again only if the operator's layout changes
PetscErrorCode make_scatter(Stars& s, Mat A)
{
  PetscFunctionBeginUser;
  PetscCall(MatGetLocalSize(A, &s.local_rows, nullptr));
  IS rows;
  Vec x;
  PetscCall(ISCreateGeneral(PETSC_COMM_SELF, s.rows.size(), s.rows.data(), PETSC_USE_POINTER,
                            &rows));
  PetscCall(MatCreateVecs(A, &x, nullptr));
  PetscCall(VecCreateSeq(PETSC_COMM_SELF, s.rows.size(), &s.in));
  PetscCall(VecDuplicate(s.in, &s.out));
  PetscCall(VecScatterCreate(x, rows, s.in, nullptr, &s.scatter));
  PetscCall(VecDestroy(&x));
  PetscCall(ISDestroy(&rows));
  PetscFunctionReturn(0);
}

PetscErrorCode setup_patches(PC pc)
{
  PetscFunctionBeginUser;
  Stars& s = stars_of(pc);
  if (!s.given)
    SETERRQ(PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_WRONGSTATE,
            "-pc_type stars: this preconditioner has no patches; it relaxes the vertex "
            "stars of p-multigrid's degree-2 level (-fieldsplit_u_mg_levels_pc_type stars) "
            "and nowhere else");
  PetscCall(PetscLogEventBegin(factor_event, pc, 0, 0, 0));
  PetscInt local_rows;
  PetscCall(MatGetLocalSize(pc->pmat, &local_rows, nullptr));
  if (s.scatter and local_rows != s.local_rows)
    PetscCall(reset(s));
  if (!s.scatter)
    PetscCall(make_scatter(s, pc->pmat));
  // Owned rows are read from the operator itself; only the ghost rows are fetched,
  // with their columns among the patches' rows.  A copy of every patch row (PETSc's
  // MatCreateSubMatrices on all of them) would copy A_gamma at each set-up, a large
  // share of the peak memory (BENCHMARKS.md, "Preconditioners against kappa").
  // s.rows is sorted, so the owned ones are the positions [owned_begin, owned_end).
  PetscInt row_begin, row_end;
  PetscCall(MatGetOwnershipRange(pc->pmat, &row_begin, &row_end));
  const PetscInt owned_begin
      = std::lower_bound(s.rows.begin(), s.rows.end(), row_begin) - s.rows.begin();
  const PetscInt owned_end
      = std::lower_bound(s.rows.begin(), s.rows.end(), row_end) - s.rows.begin();
  std::vector<PetscInt> ghost_rows(s.rows.begin(), s.rows.begin() + owned_begin);
  ghost_rows.insert(ghost_rows.end(), s.rows.begin() + owned_end, s.rows.end());
  IS ghosts, columns;
  Mat* sub;
  PetscCall(ISCreateGeneral(PETSC_COMM_SELF, ghost_rows.size(), ghost_rows.data(),
                            PETSC_USE_POINTER, &ghosts));
  PetscCall(ISCreateGeneral(PETSC_COMM_SELF, s.rows.size(), s.rows.data(), PETSC_USE_POINTER,
                            &columns));
  PetscCall(MatCreateSubMatrices(pc->pmat, 1, &ghosts, &columns, MAT_INITIAL_MATRIX, &sub));
  PetscCall(ISDestroy(&ghosts));
  PetscCall(ISDestroy(&columns));
  // an owned column's position in s.rows (-1: in no patch); other columns by search
  std::vector<PetscInt> owned_position(row_end - row_begin, -1);
  for (PetscInt q = owned_begin; q < owned_end; ++q)
    owned_position[s.rows[q] - row_begin] = q;
  auto position_of = [&](PetscInt column) -> PetscInt
  {
    if (column >= row_begin and column < row_end)
      return owned_position[column - row_begin];
    const auto at = std::lower_bound(s.rows.begin(), s.rows.end(), column);
    return at != s.rows.end() and *at == column ? at - s.rows.begin() : -1;
  };

  std::vector<PetscInt> in_patch(s.rows.size(), -1); // a row's place in the current patch
  std::size_t size = 0;
  for (std::size_t p = 0; p + 1 < s.offsets.size(); ++p)
    size += std::size_t(s.offsets[p + 1] - s.offsets[p]) * (s.offsets[p + 1] - s.offsets[p]);
  // single precision by default: the relaxation reads the inverses at every
  // application and is memory-bound; the same Krylov counts in less time
  // (BENCHMARKS.md, "Preconditioners against kappa")
  PetscBool keep_double = PETSC_FALSE;
  PetscCall(PetscOptionsGetBool(((PetscObject)pc)->options, ((PetscObject)pc)->prefix,
                                "-pc_stars_double", &keep_double, nullptr));
  s.single = !keep_double;
  s.inverses.assign(s.single ? 0 : size, 0.0);
  s.inverses_single.assign(s.single ? size : 0, 0.0f);
  std::vector<double> work(s.single ? std::size_t(s.largest) * s.largest : 0);
  std::size_t at = 0;
  bool singular = false;
  for (std::size_t p = 0; p + 1 < s.offsets.size(); ++p)
  {
    const PetscInt begin = s.offsets[p], m = s.offsets[p + 1] - begin;
    for (PetscInt k = 0; k < m; ++k)
      in_patch[s.positions[begin + k]] = k;
    // a single inverse is formed in double in `work`, then rounded
    Eigen::Map<Eigen::MatrixXd> block(s.single ? work.data() : s.inverses.data() + at, m, m);
    block.setZero();
    for (PetscInt k = 0; k < m; ++k)
    {
      PetscInt n;
      const PetscInt* cols;
      const PetscScalar* values;
      const PetscInt q = s.positions[begin + k];
      if (q >= owned_begin and q < owned_end)
      {
        PetscCall(MatGetRow(pc->pmat, s.rows[q], &n, &cols, &values));
        for (PetscInt j = 0; j < n; ++j)
          if (const PetscInt c = position_of(cols[j]); c >= 0)
            if (const PetscInt l = in_patch[c]; l >= 0)
              block(k, l) = values[j];
        PetscCall(MatRestoreRow(pc->pmat, s.rows[q], &n, &cols, &values));
      }
      else
      {
        const PetscInt ghost = q < owned_begin ? q : q - (owned_end - owned_begin);
        PetscCall(MatGetRow(sub[0], ghost, &n, &cols, &values)); // columns: positions
        for (PetscInt j = 0; j < n; ++j)
          if (const PetscInt l = in_patch[cols[j]]; l >= 0)
            block(k, l) = values[j];
        PetscCall(MatRestoreRow(sub[0], ghost, &n, &cols, &values));
      }
    }
    for (PetscInt k = 0; k < m; ++k)
      in_patch[s.positions[begin + k]] = -1;
    // a pivot at round-off of the block's size (or NaN): singular, as PETSc's LU
    // would judge it, not an inverse of 1e17
    const double norm = m > 0 ? block.cwiseAbs().rowwise().sum().maxCoeff() : 0.0;
    const Eigen::PartialPivLU<Eigen::MatrixXd> lu(block);
    singular = singular
               or !(lu.matrixLU().diagonal().cwiseAbs().array()
                    > 100 * std::numeric_limits<double>::epsilon() * norm)
                       .all();
    block = lu.inverse();
    singular = singular or !block.allFinite();
    if (s.single)
    {
      Eigen::Map<Eigen::MatrixXf> rounded(s.inverses_single.data() + at, m, m);
      rounded = block.cast<float>();
      singular = singular or !rounded.allFinite(); // beyond float's range
    }
    at += m * m;
  }
  PetscCall(MatDestroySubMatrices(1, &sub));
  PetscCall(PetscLogEventEnd(factor_event, pc, 0, 0, 0));
  // a failure, not an error: the Newton solve cuts its step (linear_failure.h); on
  // every rank, as the failure walk may run on any one alone
  MPI_Comm comm = PetscObjectComm((PetscObject)pc);
  int any_singular = singular;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &any_singular, 1, MPI_INT, MPI_LOR, comm));
  PetscCall(PCSetFailedReason(pc, any_singular ? PC_FACTOR_NUMERIC_ZEROPIVOT : PC_NOERROR));
  long local[2] = {long(s.offsets.size()) - 1, long(s.largest)};
  PetscCallMPI(MPI_Allreduce(&local[0], &s.total_patches, 1, MPI_LONG, MPI_SUM, comm));
  PetscCallMPI(MPI_Allreduce(&local[1], &s.total_largest, 1, MPI_LONG, MPI_MAX, comm));
  PetscFunctionReturn(0);
}

/// PETSc calls through C: no exception may leave
PetscErrorCode setup(PC pc)
{
  try
  {
    return setup_patches(pc);
  }
  catch (const std::bad_alloc&)
  {
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_MEM, "vertex stars: out of memory for the blocks' inverses");
  }
}

/// out += sum_p R_p^T A_p^-1 R_p in, with the inverses in precision T
template <typename T>
void add_corrections(const Stars& s, const std::vector<T>& inverses, const PetscScalar* in,
                     PetscScalar* out)
{
  using Vector = Eigen::Matrix<T, Eigen::Dynamic, 1>;
  using Matrix = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>;
  std::vector<T> work(2 * s.largest); // allocated only here in the relaxation
  Eigen::Map<Vector> r(work.data(), s.largest), z(work.data() + s.largest, s.largest);
  std::size_t at = 0;
  for (std::size_t p = 0; p + 1 < s.offsets.size(); ++p)
  {
    const PetscInt begin = s.offsets[p], m = s.offsets[p + 1] - begin;
    for (PetscInt k = 0; k < m; ++k)
      r[k] = in[s.positions[begin + k]];
    Eigen::Map<const Matrix> inverse(inverses.data() + at, m, m);
    z.head(m).noalias() = inverse * r.head(m);
    for (PetscInt k = 0; k < m; ++k)
      out[s.positions[begin + k]] += z[k];
    at += m * m;
  }
}

PetscErrorCode relax(PC pc, Vec x, Vec y)
{
  PetscFunctionBeginUser;
  Stars& s = stars_of(pc);
  PetscCall(PetscLogEventBegin(relax_event, pc, x, y, 0));
  PetscCall(VecScatterBegin(s.scatter, x, s.in, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(s.scatter, x, s.in, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecSet(s.out, 0.0));
  const PetscScalar* in;
  PetscScalar* out;
  PetscCall(VecGetArrayRead(s.in, &in));
  PetscCall(VecGetArray(s.out, &out));
  if (s.single)
    add_corrections<float>(s, s.inverses_single, in, out);
  else
    add_corrections<double>(s, s.inverses, in, out);
  PetscCall(VecRestoreArrayRead(s.in, &in));
  PetscCall(VecRestoreArray(s.out, &out));
  PetscCall(VecSet(y, 0.0));
  PetscCall(VecScatterBegin(s.scatter, s.out, y, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecScatterEnd(s.scatter, s.out, y, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(PetscLogEventEnd(relax_event, pc, x, y, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode apply(PC pc, Vec x, Vec y)
{
  try
  {
    return relax(pc, x, y);
  }
  catch (const std::bad_alloc&)
  {
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_MEM, "vertex stars: out of memory");
  }
}

PetscErrorCode view(PC pc, PetscViewer viewer)
{
  PetscFunctionBeginUser;
  PetscBool ascii;
  PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &ascii));
  if (!ascii)
    PetscFunctionReturn(0);
  const Stars& s = stars_of(pc); // the totals of the last set-up: no collective here
  PetscCall(PetscViewerASCIIPrintf(viewer,
                                   "  vertex stars: %ld patches, at most %ld unknowns each, "
                                   "each block inverted (dense LU, kept in %s precision), "
                                   "added\n",
                                   s.total_patches, s.total_largest,
                                   s.single ? "single" : "double"));
  PetscFunctionReturn(0);
}

/// PCReset (KSPReset): the scatter is made again at the next set-up
PetscErrorCode reset_pc(PC pc)
{
  PetscFunctionBeginUser;
  PetscCall(reset(stars_of(pc)));
  PetscFunctionReturn(0);
}

PetscErrorCode destroy(PC pc)
{
  PetscFunctionBeginUser;
  PetscCall(reset(stars_of(pc)));
  delete static_cast<Stars*>(pc->data);
  pc->data = nullptr;
  PetscFunctionReturn(0);
}

PetscErrorCode create(PC pc)
{
  PetscFunctionBeginUser;
  pc->data = new Stars;
  pc->ops->setup = setup;
  pc->ops->apply = apply;
  pc->ops->view = view;
  pc->ops->reset = reset_pc;
  pc->ops->destroy = destroy;
  PetscFunctionReturn(0);
}
} // namespace

void register_star_relaxation()
{
  static bool registered = false;
  if (!registered)
  {
    PCRegister(PCSTARS, create);
    PetscLogEventRegister("PCStarsFactor", PC_CLASSID, &factor_event);
    PetscLogEventRegister("PCStarsRelax", PC_CLASSID, &relax_event);
  }
  registered = true;
}

void set_star_patches(PC pc, std::span<const IS> patches)
{
  PetscBool stars = PETSC_FALSE;
  PetscObjectTypeCompare(reinterpret_cast<PetscObject>(pc), PCSTARS, &stars);
  if (!stars)
    throw std::logic_error("set_star_patches: the preconditioner is not of type stars");
  Stars& s = stars_of(pc);
  if (reset(s))
    throw std::runtime_error("set_star_patches: PETSc could not free the old scatter");
  std::vector<PetscInt> dofs;
  s.offsets.assign(1, 0);
  s.largest = 0;
  for (IS patch : patches)
  {
    PetscInt n;
    const PetscInt* indices;
    ISGetLocalSize(patch, &n);
    ISGetIndices(patch, &indices);
    dofs.insert(dofs.end(), indices, indices + n);
    ISRestoreIndices(patch, &indices);
    s.offsets.push_back(dofs.size());
    s.largest = std::max(s.largest, n);
  }
  s.rows = dofs;
  std::sort(s.rows.begin(), s.rows.end());
  s.rows.erase(std::unique(s.rows.begin(), s.rows.end()), s.rows.end());
  s.positions.resize(dofs.size());
  for (std::size_t k = 0; k < dofs.size(); ++k)
    s.positions[k] = std::lower_bound(s.rows.begin(), s.rows.end(), dofs[k]) - s.rows.begin();
  s.given = true;
}

} // namespace muscle
