// linear: gmres-schur and gmres-stars on the Taylor-Hood system [u | q]: the
// upper block factorisation of the Newton matrix, by PCFIELDSPLIT or by a shell
// of our own (p-multigrid, vertex stars, the augmented Lagrangian).
#include "fem/linear/taylor_hood_split.h"

#include "common/errors.h"
#include "common/petsc_options.h"
#include "fem/constraints/constraint.h"
#include "fem/linear/augmented_lagrangian.h"
#include "fem/linear/linear_failure.h"
#include "fem/linear/p_multigrid.h"
#include "fem/linear/rigid_body_modes.h"
#include "fem/linear/saddle_parts.h"
#include "fem/linear/star_relaxation.h"
#include "fem/linear/vertex_star.h"
#include "material/material_point.h"
#include "material/parameters.h"

#include <cmath>
#include <cstdlib>
#include <dolfinx/la/Vector.h>
#include <sstream>

using namespace dolfinx;

namespace muscle
{
namespace
{
double shear_modulus_at_rest(const ParameterSet& parameters, const std::string& kernels)
{
  // the isotropic part of the tangent A = dP/dF at F = I: for lambda I x I +
  // mu (I (x) I + I (x)^T I), 3 A_iJiJ - A_iiJJ = 30 mu
  const Tangent3 A = MaterialPointModel(parameters, kernels).tangent(point_at(
      {1, 0, 0, 0, 1, 0, 0, 0, 1}));
  double s1 = 0, s2 = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
    {
      s1 += A[27 * i + 9 * j + 3 * i + j];
      s2 += A[27 * i + 9 * i + 3 * j + j];
    }
  const double mu = (3 * s1 - s2) / 30;
  if (!(mu > 0) or !std::isfinite(mu))
    throw InputError("the Schur preconditioner of the Taylor-Hood system needs a positive "
                     "shear modulus at rest; this law's is " + std::to_string(mu)
                     + ": use linear: lu");
  return mu;
}

/// x as a person writes it (6 significant digits, no trailing zeros)
std::string shortest(double x)
{
  std::ostringstream out;
  out << x;
  return out.str();
}

/// BoomerAMG's defaults for a displacement operator under `prefix` (the block
/// itself, or p-multigrid's degree-1 level); `nodal`: the operator has the block
/// size of 3 (a constrained u has not); `interp_variant`: how the interpolation
/// takes in the rigid-body modes (nodal only)
void set_boomeramg_defaults(const std::string& prefix, bool nodal, const char* interp_variant)
{
  // Its scalar defaults ignore that u has three components, and its plain nodal
  // coarsening fills the coarse operators in.  These settings cut GAMG's Krylov
  // count on the fusiform muscle, more so on the finer mesh, but a V-cycle costs more
  // (BENCHMARKS.md, "Preconditioners against kappa"), so GAMG stays the default.
  const std::string type = string_option((prefix + "pc_hypre_type").c_str());
  if (string_option((prefix + "pc_type").c_str()) != "hypre"
      or !(type.empty() or type == "boomeramg"))
    return;
  std::vector<std::pair<std::string, std::string>> defaults
      = {{"coarsen_type", "HMIS"}, {"interp_type", "ext+i"}, {"strong_threshold", "0.5"},
         {"agg_nl", "1"},          {"P_max", "4"}};
  if (nodal)
    defaults.insert(defaults.end(),
                    {{"nodal_coarsen", "6"}, {"vec_interp_variant", interp_variant}});
  for (const auto& [name, value] : defaults)
    set_unless_given((prefix + "pc_hypre_boomeramg_" + name).c_str(), value.c_str());
}
} // namespace

void refuse_taylor_hood_split_options(bool taylor_hood, const std::string& linear_solver)
{
  const std::pair<const char*, const char*> pmg[]
      = {{"-fieldsplit_u_mg_coarse_lag", ""},
         {"-fieldsplit_u_mg_levels_pc_stars_double", " with -fieldsplit_u_mg_levels_pc_type stars"}};
  for (const auto& [name, with] : pmg)
  {
    PetscBool given = PETSC_FALSE;
    PetscOptionsHasName(nullptr, nullptr, name, &given);
    if (given)
      throw InputError(std::string(name) + ": an option of p-multigrid on Taylor-Hood's "
                       "displacement block (linear: gmres-schur, -fieldsplit_u_pc_type mg"
                       + with + "), which this run does not use; leave it out");
  }
  PetscBool given = PETSC_FALSE;
  PetscOptionsHasName(nullptr, nullptr, "-al_gamma", &given);
  if (given)
    throw InputError(std::string("-al_gamma: the augmented-Lagrangian form of the Taylor-Hood "
                                 "split, for element.taylor_hood: true with linear: "
                                 "gmres-schur only; this run has ")
                     + (taylor_hood ? "" : "element.taylor_hood: false, ")
                     + "linear: " + linear_solver);
}

void TaylorHoodSplit::set_stars_defaults()
{
  // the kappa candidate "..., stars, BoomerAMG, lag 2": flat in kappa and slowly growing
  // with the mesh on the fusiform, also under the free contraction's constraint
  // (BENCHMARKS.md, "Preconditioners against kappa")
  set_unless_given("-fieldsplit_u_pc_type", "mg");
  // the multigrid's own options only under it: the split's constructor would blame
  // the user for options the preset set
  if (string_option("-fieldsplit_u_pc_type") == "mg")
    set_unless_given({{"-fieldsplit_u_mg_levels_pc_type", PCSTARS},
                      {"-fieldsplit_u_mg_coarse_pc_type", "hypre"},
                      {"-fieldsplit_u_mg_coarse_lag", "2"}});
  // the q block's Schur approximation, the degree-1 mass matrix in a 2 x 2 pattern per
  // node, by eight Chebyshev steps on Jacobi of the node blocks in place of MUMPS's
  // factor, which grows faster than the unknowns.  Jacobi keeps a constant node block
  // times a trilinear mass matrix on parallelepipeds in [1/8, 27/8] (Wathen; linear
  // tetrahedra [1/2, 5/2]); the bounds hold on the fusiform's curved cells and varying
  // blocks by measurement, and fixed bounds and steps make a fixed linear
  // preconditioner.  About MUMPS's counts in less memory and time
  // (BENCHMARKS.md, "Preconditioners against kappa").  All or nothing: a q solver or
  // factor the user chose is left alone, with the factor that is the split's default
  if (string_option("-fieldsplit_q_ksp_type").empty()
      and string_option("-fieldsplit_q_pc_type").empty() and !factor_options_given("fieldsplit_q_"))
    set_unless_given({{"-fieldsplit_q_ksp_type", "chebyshev"},
                      {"-fieldsplit_q_ksp_max_it", "8"},
                      {"-fieldsplit_q_ksp_norm_type", "none"},
                      {"-fieldsplit_q_pc_type", "pbjacobi"},
                      {"-fieldsplit_q_ksp_chebyshev_eigenvalues", "0.12,3.4"}});
}

TaylorHoodSplit::TaylorHoodSplit(const LinearSettings& settings, DisplacementSpace space,
                                 DirichletBCs bcs, const ParameterSet& parameters,
                                 const std::string& kernels, double al_gamma)
    : _settings(settings), _space(std::move(space)), _bcs(std::move(bcs)), _al_gamma(al_gamma)
{
  // p-multigrid's own options only under it (PETSc would ignore them without a word)
  const bool pmg = string_option("-fieldsplit_u_pc_type") == "mg";
  const bool stars = pmg and string_option("-fieldsplit_u_mg_levels_pc_type") == PCSTARS;
  const std::pair<const char*, bool> ours[] = {{"-fieldsplit_u_mg_coarse_lag", pmg},
                                               {"-fieldsplit_u_mg_levels_pc_stars_double", stars}};
  for (const auto& [name, read] : ours)
  {
    PetscBool given = PETSC_FALSE;
    PetscOptionsHasName(nullptr, nullptr, name, &given);
    if (given and !read)
      throw InputError(std::string(name) + ": an option of p-multigrid on Taylor-Hood's "
                       "displacement block (linear: gmres-schur, -fieldsplit_u_pc_type mg"
                       + (name == ours[1].first ? " with -fieldsplit_u_mg_levels_pc_type stars"
                                                : "")
                       + "), which this run does not use; leave it out");
  }
  PetscBool given = PETSC_FALSE;
  PetscOptionsHasName(nullptr, nullptr, "-al_gamma", &given);
  if (given)
  {
    const std::string text = string_option("-al_gamma");
    char* end = nullptr;
    _al_gamma = std::strtod(text.c_str(), &end);
    if (text.empty() or *end != '\0' or !(_al_gamma > 0) or !std::isfinite(_al_gamma))
      throw InputError("-al_gamma '" + text
                       + "': the augmented Lagrangian's penalty over the law's shear "
                         "modulus at rest must be a number > 0 (1 is a good start); leave "
                         "the option out for the plain Schur split");
  }
  _shear_modulus = shear_modulus_at_rest(parameters, kernels);
  // A_gamma is summed during the Jacobian's assembly: it must exist before the first
  if (_al_gamma > 0)
    _augmented = std::make_unique<AugmentedLagrangian>(_al_gamma * _shear_modulus);
}

TaylorHoodSplit::~TaylorHoodSplit() = default;

void TaylorHoodSplit::configure(KSP ksp, const TaylorHoodBlocks& blocks)
{
  _blocks = blocks;
  configure_gmres(ksp, _settings.linear_rtol);
  PC pc;
  KSPGetPC(ksp, &pc);
  configure_field_split(pc);
  KSPSetPCSide(ksp, PC_RIGHT);
}

void TaylorHoodSplit::update()
{
  if (_schur_pre)
    update_schur_preconditioner();
  if (_u_ksp)
    update_shell();
}

void TaylorHoodSplit::start_solve()
{
  LinearSolver::start_solve();
  // a lagged Galerkin matrix from another step, or from the rejected iterates of
  // a cut one, may be far from this solve's Jacobians
  if (_coarsening)
    _coarsening->refresh_at_next_call();
}

void TaylorHoodSplit::update_schur_preconditioner()
{
  // S ~ A_qq - A_qu A^-1 A_uq with A_uq A^-1 A_qu ~ M / mu on p (Taylor-Hood
  // Stokes: the pressure mass matrix over the shear modulus).  A_qq's (theta, p)
  // block is -M exactly.  With the augmented Lagrangian, B A_gamma^-1 B^T ~
  // M / (mu + gamma), and the displacement rows' share gamma B^T W^-1 (-M) of
  // the theta columns (W ~ M) takes gamma / (mu + gamma) of -M out of the
  // (p, theta) block: p rows (p, theta) -M mu / (mu + gamma), (p, p)
  // -M / (mu + gamma); gamma = 0 leaves A_qq's (p, theta) block as it is.
  const double mu = _shear_modulus;
  const double gamma = _augmented ? _augmented->gamma() : 0.0;
  MatCopy(_blocks.qq, _schur_pre, SAME_NONZERO_PATTERN);
  PetscInt start, end;
  MatGetOwnershipRange(_blocks.qq, &start, &end);
  for (PetscInt row = start; row < end; row += 2) // theta rows: even
  {
    PetscInt n;
    const PetscInt* cols;
    const PetscScalar* values;
    MatGetRow(_blocks.qq, row, &n, &cols, &values); // (theta, p): -M, symmetric
    std::vector<PetscInt> p_cols;
    std::vector<PetscScalar> p_values;
    for (PetscInt k = 0; k < n; ++k)
      if (cols[k] % 2 == 1)
      {
        p_cols.insert(p_cols.end(), {cols[k] - 1, cols[k]});
        p_values.insert(p_values.end(),
                        {values[k] * mu / (mu + gamma), values[k] / (mu + gamma)});
      }
    MatRestoreRow(_blocks.qq, row, &n, &cols, &values);
    const PetscInt p_row = row + 1;
    MatSetValues(_schur_pre, 1, &p_row, p_cols.size(), p_cols.data(), p_values.data(),
                 INSERT_VALUES);
  }
  MatAssemblyBegin(_schur_pre, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_schur_pre, MAT_FINAL_ASSEMBLY);
}

void TaylorHoodSplit::configure_field_split(PC pc)
{
  // The displacement block sees the energy at F_bar with theta held: its
  // stiffness is the deviatoric one, free of kappa; kappa lives in the q block.
  // It has no bulk stiffness either (a dilation leaves F_bar alone), which AMG
  // coarsens poorly: GAMG alone needs far more iterations on it than on plain Q2's
  // whole matrix (BENCHMARKS.md, "Preconditioners against kappa"); the outer GMRES
  // corrects what one V-cycle leaves.  Schur
  // complement of q, approximated by A_qq with -M / mu in its pp part
  // (update_schur_preconditioner) and factored (q is small: two unknowns per
  // degree-1 node).  The kappa part is kept exactly and the pair is inf-sup
  // stable, so the count does not grow with kappa.
  // (the blocks' solvers and their multigrid levels, p-multigrid's and GAMG's alike)
  require_flexible_outer_under("fieldsplit_", "Taylor-Hood preconditioner");
  MatDuplicate(_blocks.qq, MAT_COPY_VALUES, _schur_pre.out());
  update_schur_preconditioner();
  if (_augmented or string_option("-fieldsplit_u_pc_type") == "mg")
  {
    configure_shell(pc);
    return;
  }
  PetscInt n, start, end;
  n = _blocks.nu;
  VecGetOwnershipRange(_blocks.iterate, &start, &end);
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(_blocks.qq));
  IS u, q;
  ISCreateStride(comm, n, start, 1, &u);
  ISCreateStride(comm, end - start - n, start + n, 1, &q);
  if (!_space.constraint)
    ISSetBlockSize(u, 3); // GAMG aggregates nodes
  *_modes.out() = rigid_body_modes(*_space.V, _space.constraint,
                                   _settings.near_null_space == "bodies");
  PetscObjectCompose(reinterpret_cast<PetscObject>(u), "nearnullspace",
                     reinterpret_cast<PetscObject>(_modes.get()));
  PCSetType(pc, PCFIELDSPLIT);
  PCFieldSplitSetIS(pc, "u", u);
  PCFieldSplitSetIS(pc, "q", q);
  ISDestroy(&u);
  ISDestroy(&q);
  PCFieldSplitSetType(pc, PC_COMPOSITE_SCHUR);
  PCFieldSplitSetSchurFactType(pc, PC_FIELDSPLIT_SCHUR_FACT_UPPER);
  PCFieldSplitSetSchurPre(pc, PC_FIELDSPLIT_SCHUR_PRE_USER, _schur_pre);
  // the sub-solvers through their option prefixes: -fieldsplit_* given by the
  // user win
  set_unless_given({{"-fieldsplit_u_ksp_type", "preonly"},
                    {"-fieldsplit_u_pc_type", "gamg"},
                    {"-fieldsplit_q_ksp_type", "preonly"},
                    {"-fieldsplit_q_pc_type", "lu"},
                    {"-fieldsplit_q_pc_factor_mat_solver_type", "mumps"}});
  set_boomeramg_defaults("-fieldsplit_u_", _space.constraint == nullptr, "2");
}

void TaylorHoodSplit::configure_shell(PC pc)
{
  const bool pmg = string_option("-fieldsplit_u_pc_type") == "mg";
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(_blocks.qq));
  PetscInt n;
  n = _blocks.nu;
  PetscInt size;
  VecGetLocalSize(_blocks.iterate, &size);
  const PetscInt nq = size - n;
  VecCreateMPIWithArray(comm, 1, n, PETSC_DECIDE, nullptr, _u_in.out());
  VecCreateMPIWithArray(comm, 1, n, PETSC_DECIDE, nullptr, _u_out.out());
  VecCreateMPIWithArray(comm, 1, nq, PETSC_DECIDE, nullptr, _q_in.out());
  VecCreateMPIWithArray(comm, 1, nq, PETSC_DECIDE, nullptr, _q_out.out());
  VecCreateMPI(comm, n, PETSC_DETERMINE, _u_rhs.out());

  // the options the field split would read, under the same prefixes; Jacobi on
  // the degree-2 level, not PCMG's SOR: a few more Krylov iterations in less time
  // (BENCHMARKS.md, "Preconditioners against kappa")
  set_unless_given({{"-fieldsplit_q_pc_type", "lu"},
                    {"-fieldsplit_q_pc_factor_mat_solver_type", "mumps"},
                    {"-fieldsplit_u_pc_type", "gamg"},
                    {"-fieldsplit_u_mg_levels_pc_type", "jacobi"}});
  set_boomeramg_defaults("-fieldsplit_u_", _space.constraint == nullptr, "2");
  // variant 1 on the degree-1 level: the fewest Krylov iterations on the bending
  // cantilever, even with variant 2 on the fusiform (BENCHMARKS.md, "Preconditioners
  // against kappa" and "Taylor-Hood (Q2-Q1)"); the degree-1 space is never
  // constrained, whole nodes of block size 3 (under a constraint R P maps it onto
  // the reduced unknowns)
  if (pmg)
    set_boomeramg_defaults("-fieldsplit_u_mg_coarse_", true, "1");
  KSPCreate(comm, _q_ksp.out());
  KSPSetOptionsPrefix(_q_ksp, "fieldsplit_q_");
  KSPSetType(_q_ksp, KSPPREONLY);
  KSPSetOperators(_q_ksp, _schur_pre, _schur_pre);
  KSPSetFromOptions(_q_ksp);

  KSPCreate(comm, _u_ksp.out());
  KSPSetOptionsPrefix(_u_ksp, "fieldsplit_u_");
  KSPSetType(_u_ksp, KSPPREONLY);
  PC u_pc;
  KSPGetPC(_u_ksp, &u_pc);
  if (pmg)
  {
    std::vector<std::int32_t> dirichlet;
    for (const auto& bc : _bcs)
    {
      auto [dofs, owned] = bc->dof_indices();
      dirichlet.insert(dirichlet.end(), dofs.begin(), dofs.end());
    }
    _coarsening = std::make_unique<DegreeOneCoarsening>(_space.V, dirichlet);
    if (_space.constraint)
    {
      Mat R = _space.constraint->restriction();
      _coarsening->restrict_rows(R);
      MatDestroy(&R);
    }
    PCSetType(u_pc, PCMG);
    PCMGSetLevels(u_pc, 2, nullptr);
    PCMGSetInterpolation(u_pc, 1, _coarsening->prolongation());
    PCMGSetGalerkin(u_pc, PC_MG_GALERKIN_NONE); // P^T A P formed here, with its modes
    KSP coarse;
    PCMGGetCoarseSolve(u_pc, &coarse);
    KSPSetType(coarse, KSPPREONLY);
    PC amg;
    KSPGetPC(coarse, &amg);
    PCSetType(amg, PCGAMG);
    if (string_option("-fieldsplit_u_mg_levels_pc_type") == PCSTARS)
      use_vertex_star_smoother(u_pc);
  }
  if (!pmg)
    *_modes.out() = rigid_body_modes(*_space.V, _space.constraint,
                                     _settings.near_null_space == "bodies");
  // the Galerkin level's values wait for the first Newton iteration: a product of
  // this Jacobian would be replaced there (each solve starts with a new one), a
  // numeric product wasted; its structure (and options) now
  update_shell(false);
  KSPSetFromOptions(_u_ksp);

  PCSetType(pc, PCSHELL);
  PCShellSetContext(pc, this);
  PCShellSetApply(pc, shell_apply);
  std::string name = "Taylor-Hood Schur factorisation";
  if (_augmented)
    name += ", augmented Lagrangian (gamma "
            + shortest(_augmented->gamma()) + " kPa)";
  name += pmg ? ", p-multigrid on u" : ", " + string_option("-fieldsplit_u_pc_type") + " on u";
  if (pmg and _coarsening->lag() > 1)
    name += " (its Q1 product every " + std::to_string(_coarsening->lag())
            + " Newton iterations)";
  PCShellSetName(pc, name.c_str());
  PCShellSetView(pc, [](PC shell, PetscViewer viewer) -> PetscErrorCode
  {
    TaylorHoodSplit* self;
    PCShellGetContext(shell, &self);
    KSPView(self->_q_ksp, viewer);
    KSPView(self->_u_ksp, viewer);
    return 0;
  });
}

void TaylorHoodSplit::use_vertex_star_smoother(PC u_pc)
{
  // one patch per owned vertex: PCASM's own subdomains (one block per rank,
  // grown by overlap) know nothing of the mesh, and stars are what relax the
  // augmented block's near-kernel
  KSP smoother;
  PCMGGetSmoother(u_pc, 1, &smoother);
  PC stars;
  KSPGetPC(smoother, &stars);
  register_star_relaxation();
  PCSetType(stars, PCSTARS);
  std::vector<IS> patches = _space.constraint ? reduced_star_patches()
                                        : vertex_star_patches(*_space.V);
  set_star_patches(stars, patches);
  for (IS& patch : patches)
    ISDestroy(&patch);
}

std::vector<IS> TaylorHoodSplit::reduced_star_patches() const
{
  // the full space's stars renumbered to T^T A T's rows, the dofs the constraint
  // sets left out; the reduced unknowns no star holds (the uniform-axial value)
  // one block more, so that the smoother reaches every unknown
  const fem::FunctionSpace& V = *_space.V;
  la::Vector<double> numbers(V.dofmap()->index_map, V.dofmap()->index_map_bs());
  const std::vector<std::int64_t> owned = _space.constraint->reduced_numbers();
  std::copy(owned.begin(), owned.end(), numbers.mutable_array().begin());
  numbers.scatter_fwd();
  std::vector<std::int64_t> local(numbers.array().begin(), numbers.array().end());
  std::vector<IS> patches = vertex_star_patches(V, local);
  PetscInt start, end;
  MatGetOwnershipRangeColumn(_space.constraint->T(), &start, &end);
  std::vector<char> held(end - start, 0);
  for (IS patch : patches)
  {
    PetscInt size;
    const PetscInt* rows;
    ISGetLocalSize(patch, &size);
    ISGetIndices(patch, &rows);
    for (PetscInt k = 0; k < size; ++k)
      if (rows[k] >= start and rows[k] < end)
        held[rows[k] - start] = 1;
    ISRestoreIndices(patch, &rows);
  }
  std::vector<PetscInt> left;
  for (PetscInt row = start; row < end; ++row)
    if (!held[row - start])
      left.push_back(row);
  if (!left.empty())
  {
    IS patch;
    ISCreateGeneral(PETSC_COMM_SELF, left.size(), left.data(), PETSC_COPY_VALUES, &patch);
    patches.push_back(patch);
  }
  return patches;
}

void TaylorHoodSplit::update_shell(bool coarse)
{
  // A changes in place (with the augmented Lagrangian it holds A_gamma); the
  // near-null space goes on each time (GAMG reads it at set-up)
  Mat op = _blocks.uu;
  if (!_coarsening)
    MatSetNearNullSpace(op, _modes);
  KSPSetOperators(_u_ksp, op, op);
  if (!_coarsening)
    return;
  PC u_pc;
  KSPGetPC(_u_ksp, &u_pc);
  // PCMG keeps the fine level's smoother operator and residual matrix from its
  // first set-up when the new operator is another object: both from op, each time
  KSP fine;
  PCMGGetSmoother(u_pc, 1, &fine);
  KSPSetOperators(fine, op, op);
  PCMGSetResidual(u_pc, 1, PCMGResidualDefault, op);
  if (!coarse)
  {
    _coarsening->prepare(op);
    return;
  }
  Mat coarse_matrix = _coarsening->coarse_matrix(op);
  KSP coarse_solve;
  PCMGGetCoarseSolve(u_pc, &coarse_solve);
  KSPSetOperators(coarse_solve, coarse_matrix, coarse_matrix);
}

PetscErrorCode TaylorHoodSplit::shell_apply(PC pc, Vec r, Vec z)
{
  // upper factorisation: z_q = S^-1 r_q, z_u = A^-1 (r_u - A_uq z_q); with the
  // augmented Lagrangian A_gamma and its share of the constraint rows in r_u
  TaylorHoodSplit* self;
  PCShellGetContext(pc, &self);
  // a failed inner solve (or a PETSc error in it) fails this linear solve and so
  // ends the Newton solve; start_clean() clears the failure before the next one
  bool failed = false;
  // a product's or a solve's PETSc error can be one rank's alone: every rank must
  // take the same path into the collective u-solve and out of this apply
  auto agree = [&failed, comm = PetscObjectComm(reinterpret_cast<PetscObject>(pc))]()
  {
    int any_failed = failed;
    MPI_Allreduce(MPI_IN_PLACE, &any_failed, 1, MPI_INT, MPI_LOR, comm);
    failed = any_failed;
  };
  auto solve = [&failed, self](KSP ksp, Vec b, Vec x)
  {
    if (failed)
      return;
    KSPConvergedReason reason = KSP_DIVERGED_PC_FAILED;
    const PetscErrorCode error = KSPSolve(ksp, b, x);
    if (!error)
      KSPGetConvergedReason(ksp, &reason);
    failed = inner_solve_failed(reason);
    if (failed)
    {
      const char* prefix = nullptr;
      KSPGetOptionsPrefix(ksp, &prefix);
      self->_inner_failure = std::string(prefix ? prefix : "") + ": "
                             + describe_linear_failure(ksp, error);
    }
  };
  {
    SaddleParts parts(r, z, self->_u_in, self->_u_out, self->_q_in,
                      self->_q_out);
    PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
    solve(self->_q_ksp, self->_q_in, self->_q_out);
    agree(); // the product is collective
    if (!failed)
      failed = MatMult(self->_blocks.uq, self->_q_out, self->_u_rhs)
               or VecAYPX(self->_u_rhs, -1.0, self->_u_in)
               or (self->_augmented
                   and self->_augmented->add_constraint_rows(
                       self->_u_rhs, self->_q_in, self->_q_out,
                       self->_blocks.qu, self->_blocks.qq));
    agree();
    solve(self->_u_ksp, self->_u_rhs, self->_u_out);
    PetscPopErrorHandler();
  }
  agree();
  if (failed)
    fail_shell_apply(pc, z);
  return 0;
}

} // namespace muscle
