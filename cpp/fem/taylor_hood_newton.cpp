// Taylor-Hood Newton: the SNES vector is [u owned | q owned] with q = (theta, p)
// the degree-1 field of the mixed element, the Jacobian the nest of the
// displacement block (everything the displacement Newton assembles: loads,
// contact, Dirichlet rows) and the three blocks of q.  Under a linear
// constraint u = T x the displacement part is x: the blocks T^T A T, T^T A_uq
// and A_qu T.
#include "nonlinear_solver.h"

#include "../common/errors.h"
#include "../common/petsc_options.h"
#include "../material/material_point.h"
#include "augmented_lagrangian.h"
#include "constraint.h"
#include "linear_failure.h"
#include "p_multigrid.h"
#include "rigid_body_modes.h"
#include "saddle_parts.h"
#include "star_relaxation.h"
#include "vertex_star.h"

#include <cmath>
#include <cstdlib>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/la/petsc.h>
#include <limits>
#include <sstream>

using namespace dolfinx;

namespace muscle
{
namespace
{
std::int32_t owned_size(const la::Vector<double>& v)
{
  return v.map()->size_local() * v.bs();
}

/// the law's mu from its tangent at F = I (the Schur approximation's scale)
double shear_modulus_at_rest(const ParameterSet& parameters, const std::string& kernels);

/// The infinity norm of a nest of AIJ blocks, not assembled: per row, |a_ij| summed
/// over its block row (MatNorm takes a nest's Frobenius norm only).  uu is read in
/// place of the (u, u) block, which is an operator under the augmented Lagrangian:
/// A_gamma there, whose rows are larger than A's by the cells' terms.
double nest_infinity_norm(Mat nest, Mat uu)
{
  PetscInt rows, cols;
  Mat** blocks;
  MatNestGetSubMats(nest, &rows, &cols, &blocks);
  double largest = 0;
  for (PetscInt i = 0; i < rows; ++i)
  {
    PetscInt start, end;
    MatGetOwnershipRange(blocks[i][0], &start, &end);
    std::vector<double> sums(end - start, 0.0);
    for (PetscInt j = 0; j < cols; ++j)
      for (PetscInt r = start; r < end; ++r)
      {
        Mat block = i == 0 and j == 0 ? uu : blocks[i][j];
        PetscInt n;
        const PetscScalar* values;
        MatGetRow(block, r, &n, nullptr, &values);
        for (PetscInt k = 0; k < n; ++k)
          sums[r - start] += std::abs(values[k]);
        MatRestoreRow(block, r, &n, nullptr, &values);
      }
    for (double s : sums)
      largest = std::max(largest, s);
  }
  MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX,
                PetscObjectComm(reinterpret_cast<PetscObject>(nest)));
  return largest;
}
} // namespace

void NonlinearSolver::create_pressure_unknowns()
{
  if (_parts.size() != 1)
    throw InputError("Taylor-Hood elements are built for a body of one material (one part)");
  if (_options.linear_solver != "lu" and _options.linear_solver != "gmres-schur")
    throw InputError("linear solver " + _options.linear_solver
                     + ": the Taylor-Hood system (displacement and pressure) is solved by "
                       "MUMPS (linear: lu) or by GMRES with its Schur complement "
                       "(linear: gmres-schur, or gmres-stars relaxing it on vertex stars)");
  _taylor_hood = true;
  const MuscleProblem::TaylorHoodForms& f = _problem.th_forms();
  auto Q = _problem.th_state()->function_space();
  _bq = std::make_unique<la::Vector<double>>(Q->dofmap()->index_map,
                                             Q->dofmap()->index_map_bs());
  _th_blocks = {fem::petsc::create_matrix(*f.jacobian_uq, "aij"),
                fem::petsc::create_matrix(*f.jacobian_qu, "aij"),
                fem::petsc::create_matrix(*f.jacobian_qq, "aij")};
  MPI_Comm comm = _problem.mesh()->comm();
  PetscInt n;
  VecGetLocalSize(_x, &n);
  VecCreateMPI(comm, n + owned_size(*_bq), PETSC_DETERMINE, &_x_ext);
  VecDuplicate(_x, &_tmp);
  // A_gamma is summed during the Jacobian's assembly: it must exist before the first
  if (_options.linear_solver == "gmres-schur")
    _shear_modulus = shear_modulus_at_rest(_problem.parameters(), _problem.kernel_name());
  if (_al_gamma > 0)
    _augmented = std::make_unique<AugmentedLagrangian>(_al_gamma * _shear_modulus);
  // the nest and its assembled copy need the patterns before SNES holds them
  _problem.u()->x()->scatter_fwd();
  update_activation();
  assemble_mixed_jacobian();
}

void NonlinearSolver::reduce_mixed_blocks(bool first)
{
  // T^T A_uq and A_qu T: products of their own, recomputed in place later (with
  // the augmented Lagrangian T^T A T is T^T A_gamma T: A holds A_gamma)
  const MatReuse reuse = first ? MAT_INITIAL_MATRIX : MAT_REUSE_MATRIX;
  MatTransposeMatMult(_constraint->T(), _th_blocks[0], reuse, PETSC_DEFAULT, &_th_reduced[0]);
  MatMatMult(_th_blocks[1], _constraint->T(), reuse, PETSC_DEFAULT, &_th_reduced[1]);
}

void NonlinearSolver::set_mixed_state(Vec x)
{
  PetscInt n;
  VecGetLocalSize(_x, &n);
  const PetscScalar* a;
  VecGetArrayRead(x, &a);
  // q first: the activation kernels read the fibre stretch at F_bar
  auto q = _problem.th_state()->x();
  std::copy(a + n, a + n + owned_size(*q), q->mutable_array().begin());
  q->scatter_fwd();
  PetscScalar* xu;
  VecGetArray(_x, &xu);
  std::copy(a, a + n, xu);
  VecRestoreArray(_x, &xu);
  VecRestoreArrayRead(x, &a);
  set_state(_x);
}

void NonlinearSolver::get_mixed_state(Vec x)
{
  PetscInt n;
  VecGetLocalSize(_x, &n);
  PetscScalar* a;
  VecGetArray(x, &a);
  std::span<const double> u = _problem.u()->x()->array();
  std::copy(u.begin(), u.begin() + n, a);
  auto q = _problem.th_state()->x();
  std::copy(q->array().begin(), q->array().begin() + owned_size(*q), a + n);
  VecRestoreArray(x, &a);
  if (_constraint)
  {
    _constraint->restrict_to(*_problem.u()->x(), _tmp);
    const PetscScalar* t;
    VecGetArrayRead(_tmp, &t);
    VecGetArray(x, &a);
    std::copy(t, t + n, a);
    VecRestoreArray(x, &a);
    VecRestoreArrayRead(_tmp, &t);
  }
}

void NonlinearSolver::mixed_residual(Vec F)
{
  displacement_residual();
  const MuscleProblem::TaylorHoodForms& f = _problem.th_forms();
  std::span<double> bq = _bq->mutable_array();
  std::fill(bq.begin(), bq.end(), 0.0);
  fem::assemble_vector<double>(bq, *f.residual);
  // q has no Dirichlet conditions; its rows see the displacement's through dR_q/du
  fem::apply_lifting<double>(bq, {f.jacobian_qu}, {_bcs}, {_problem.u()->x()->array()}, -1.0);
  _bq->scatter_rev(std::plus<double>());
  PetscInt n;
  VecGetLocalSize(_x, &n);
  PetscScalar* a;
  VecGetArray(F, &a);
  if (_constraint)
  {
    MatMultTranspose(_constraint->T(), _F_full, _tmp);
    const PetscScalar* t;
    VecGetArrayRead(_tmp, &t);
    std::copy(t, t + n, a);
    VecRestoreArrayRead(_tmp, &t);
  }
  else
    std::copy(_b.array().begin(), _b.array().begin() + n, a);
  std::copy(bq.begin(), bq.begin() + owned_size(*_bq), a + n);
  VecRestoreArray(F, &a);
}

void NonlinearSolver::assemble_mixed_jacobian()
{
  assemble_full_jacobian();
  const MuscleProblem::TaylorHoodForms& f = _problem.th_forms();
  const std::array<const fem::Form<double>*, 3> forms
      = {f.jacobian_uq.get(), f.jacobian_qu.get(), f.jacobian_qq.get()};
  bool finite = std::isfinite(_matrix_norm);
  if (_augmented)
    _augmented->begin(_A);
  // A_qq before A_qu: the augmented Lagrangian takes each cell's lumped mass from
  // the one and sums B_c^T W_c^-1 B_c from the other, cell by cell
  for (std::size_t i : {0, 2, 1})
  {
    Mat M = _th_blocks[i];
    MatZeroEntries(M);
    auto set = la::petsc::Matrix::set_block_fn(M, ADD_VALUES);
    auto add = [&set, al = _augmented.get(), i](const std::span<const std::int32_t>& rows,
                                                const std::span<const std::int32_t>& cols,
                                                const std::span<const double>& values)
    {
      if (al and i == 2)
        al->add_cell_mass(rows, values);
      else if (al and i == 1)
        al->add_cell_coupling(rows, cols, values);
      return set(rows, cols, values);
    };
    // Dirichlet rows (of A_uq) and columns (of A_qu) zeroed: A carries unit rows there
    fem::assemble_matrix(add, *forms[i], _bcs);
    MatAssemblyBegin(M, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(M, MAT_FINAL_ASSEMBLY);
    PetscReal norm;
    MatNorm(M, NORM_FROBENIUS, &norm);
    finite = finite and std::isfinite(norm);
  }
  if (_augmented)
    _augmented->end(_th_blocks[2]);
  if (!finite)
  {
    _matrix_norm = std::numeric_limits<double>::quiet_NaN();
    return;
  }
  const bool first = !_J_nest;
  Mat A = _A;
  std::array<Mat, 2> coupling = {_th_blocks[0], _th_blocks[1]};
  if (_constraint)
  {
    reduce(_A_red, !_A_red);
    reduce_mixed_blocks(first);
    A = _A_red;
    coupling = _th_reduced;
  }
  if (first)
  {
    // with the augmented Lagrangian A holds A_gamma, and GMRES's block is A_gamma
    // less the cells' terms, an operator
    Mat uu = _augmented ? _augmented->jacobian_block(A, _constraint ? _constraint->T() : nullptr)
                        : A;
    Mat blocks[4] = {uu, coupling[0], coupling[1], _th_blocks[2]};
    MatCreateNest(_problem.mesh()->comm(), 2, nullptr, 2, nullptr, blocks, &_J_nest);
  }
  MatAssemblyBegin(_J_nest, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_J_nest, MAT_FINAL_ASSEMBLY);
  // GMRES takes the nest as it is (the split's blocks are the nest's, not copies):
  // the assembled copy was 44 % of the plain split's peak memory at n = 1, 42 % at n = 2
  if (_options.linear_solver == "lu")
  {
    // MUMPS needs the blocks in one matrix; contact can add nonzeros to A, and a
    // conversion reusing the old pattern would drop them
    PetscObjectState state;
    MatGetNonzeroState(A, &state);
    if (!_J_mixed)
      MatConvert(_J_nest, MATAIJ, MAT_INITIAL_MATRIX, &_J_mixed);
    else if (state != _mixed_state)
    {
      Mat fresh;
      MatConvert(_J_nest, MATAIJ, MAT_INITIAL_MATRIX, &fresh);
      MatSetOption(_J_mixed, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
      MatCopy(fresh, _J_mixed, DIFFERENT_NONZERO_PATTERN);
      MatDestroy(&fresh);
    }
    else
      MatConvert(_J_nest, MATAIJ, MAT_REUSE_MATRIX, &_J_mixed);
    _mixed_state = state;
    MatNorm(_J_mixed, NORM_INFINITY, &_mixed_norm);
  }
  else
    _mixed_norm = nest_infinity_norm(_J_nest, A);
  if (_schur_pre)
    update_schur_preconditioner();
  if (_u_ksp)
    update_mixed_shell();
}

double NonlinearSolver::mixed_floor(SNES snes) const
{
  // The q rows carry the stiff penalty (kappa per unit volume), and the degree-1
  // basis sums to one only to round-off, so R_theta cannot fall below about
  // eps |A_mixed| |theta| (measured: 1.5e-8 on the cantilever at rest, where
  // eps |A_mixed| |theta| = 1.5e-8); the displacement rows as in the other
  // elements, eps |A| |u|.  (theta, not p: p's round-off enters through the
  // small coupling blocks only.)
  Vec x;
  SNESGetSolution(snes, &x);
  PetscInt n;
  VecGetLocalSize(_x, &n);
  PetscInt size;
  VecGetLocalSize(x, &size);
  const PetscScalar* a;
  VecGetArrayRead(x, &a);
  double sums[2] = {0, 0};
  for (PetscInt i = 0; i < n; ++i)
    sums[0] += a[i] * a[i];
  for (PetscInt i = n; i < size; i += 2)
    sums[1] += a[i] * a[i];
  VecRestoreArrayRead(x, &a);
  MPI_Allreduce(MPI_IN_PLACE, sums, 2, MPI_DOUBLE, MPI_SUM, _problem.mesh()->comm());
  return std::numeric_limits<double>::epsilon()
         * (_matrix_norm * std::sqrt(sums[0]) + _mixed_norm * std::sqrt(sums[1]));
}

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
  // coarsening fills the coarse operators in (2.7 GB at n = 1).  These settings
  // cut GAMG's Krylov count on the fusiform muscle by a third (n = 1) to a half
  // (n = 2), but a V-cycle costs more (BENCHMARKS.md, "Preconditioners against
  // kappa"), so GAMG stays the default.
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

void NonlinearSolver::update_schur_preconditioner()
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
  MatCopy(_th_blocks[2], _schur_pre, SAME_NONZERO_PATTERN);
  PetscInt start, end;
  MatGetOwnershipRange(_th_blocks[2], &start, &end);
  for (PetscInt row = start; row < end; row += 2) // theta rows: even
  {
    PetscInt n;
    const PetscInt* cols;
    const PetscScalar* values;
    MatGetRow(_th_blocks[2], row, &n, &cols, &values); // (theta, p): -M, symmetric
    std::vector<PetscInt> p_cols;
    std::vector<PetscScalar> p_values;
    for (PetscInt k = 0; k < n; ++k)
      if (cols[k] % 2 == 1)
      {
        p_cols.insert(p_cols.end(), {cols[k] - 1, cols[k]});
        p_values.insert(p_values.end(),
                        {values[k] * mu / (mu + gamma), values[k] / (mu + gamma)});
      }
    MatRestoreRow(_th_blocks[2], row, &n, &cols, &values);
    const PetscInt p_row = row + 1;
    MatSetValues(_schur_pre, 1, &p_row, p_cols.size(), p_cols.data(), p_values.data(),
                 INSERT_VALUES);
  }
  MatAssemblyBegin(_schur_pre, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_schur_pre, MAT_FINAL_ASSEMBLY);
}

void NonlinearSolver::configure_mixed_split(PC pc)
{
  // The displacement block sees the energy at F_bar with theta held: its
  // stiffness is the deviatoric one, free of kappa; kappa lives in the q block.
  // It has no bulk stiffness either (a dilation leaves F_bar alone), which AMG
  // coarsens poorly: GAMG alone needs hundreds of iterations on it, against
  // 15 on plain Q2's whole matrix (BENCHMARKS.md, "Preconditioners against
  // kappa"); the outer GMRES corrects what one V-cycle leaves.  Schur
  // complement of q, approximated by A_qq with -M / mu in its pp part
  // (update_schur_preconditioner) and factored (q is small: two unknowns per
  // degree-1 node).  The kappa part is kept exactly and the pair is inf-sup
  // stable, so the count does not grow with kappa.
  // (the blocks' solvers and their multigrid levels, p-multigrid's and GAMG's alike)
  require_flexible_outer_under("fieldsplit_", "Taylor-Hood preconditioner");
  MatDuplicate(_th_blocks[2], MAT_COPY_VALUES, &_schur_pre);
  update_schur_preconditioner();
  if (_augmented or string_option("-fieldsplit_u_pc_type") == "mg")
  {
    configure_mixed_shell(pc);
    return;
  }
  PetscInt n, start, end;
  VecGetLocalSize(_x, &n);
  VecGetOwnershipRange(_x_ext, &start, &end);
  MPI_Comm comm = _problem.mesh()->comm();
  IS u, q;
  ISCreateStride(comm, n, start, 1, &u);
  ISCreateStride(comm, end - start - n, start + n, 1, &q);
  if (!_constraint)
    ISSetBlockSize(u, 3); // GAMG aggregates nodes
  _near_null_space = rigid_body_modes(*_problem.V(), _constraint.get(),
                                      _options.near_null_space == "bodies");
  PetscObjectCompose(reinterpret_cast<PetscObject>(u), "nearnullspace",
                     reinterpret_cast<PetscObject>(_near_null_space));
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
  set_boomeramg_defaults("-fieldsplit_u_", _constraint == nullptr, "2");
}

void NonlinearSolver::configure_mixed_shell(PC pc)
{
  const bool pmg = string_option("-fieldsplit_u_pc_type") == "mg";
  MPI_Comm comm = _problem.mesh()->comm();
  PetscInt n;
  VecGetLocalSize(_x, &n);
  const PetscInt nq = owned_size(*_bq);
  VecCreateMPIWithArray(comm, 1, n, PETSC_DECIDE, nullptr, &_mix_u_in);
  VecCreateMPIWithArray(comm, 1, n, PETSC_DECIDE, nullptr, &_mix_u_out);
  VecCreateMPIWithArray(comm, 1, nq, PETSC_DECIDE, nullptr, &_mix_q_in);
  VecCreateMPIWithArray(comm, 1, nq, PETSC_DECIDE, nullptr, &_mix_q_out);
  VecDuplicate(_x, &_mix_u_rhs);

  // the options the field split would read, under the same prefixes; Jacobi on
  // the degree-2 level, not PCMG's SOR: 35 Krylov its per Newton it against 30 at
  // n = 1, but 44 s against 76 s (BENCHMARKS.md, "Preconditioners against kappa")
  set_unless_given({{"-fieldsplit_q_pc_type", "lu"},
                    {"-fieldsplit_q_pc_factor_mat_solver_type", "mumps"},
                    {"-fieldsplit_u_pc_type", "gamg"},
                    {"-fieldsplit_u_mg_levels_pc_type", "jacobi"}});
  set_boomeramg_defaults("-fieldsplit_u_", _constraint == nullptr, "2");
  // variant 1 on the degree-1 level: on the bending cantilever 92.5 Krylov its per
  // Newton it against variant 2's 111.5 (0 and 3: 264, 275), on the fusiform even
  // (BENCHMARKS.md, "Preconditioners against kappa"); the degree-1 space is never
  // constrained, whole nodes of block size 3 (under a constraint R P maps it onto
  // the reduced unknowns)
  if (pmg)
    set_boomeramg_defaults("-fieldsplit_u_mg_coarse_", true, "1");
  KSPCreate(comm, &_q_ksp);
  KSPSetOptionsPrefix(_q_ksp, "fieldsplit_q_");
  KSPSetType(_q_ksp, KSPPREONLY);
  KSPSetOperators(_q_ksp, _schur_pre, _schur_pre);
  KSPSetFromOptions(_q_ksp);

  KSPCreate(comm, &_u_ksp);
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
    _coarsening = std::make_unique<DegreeOneCoarsening>(_problem.V(), dirichlet);
    if (_constraint)
    {
      Mat R = _constraint->restriction();
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
    _near_null_space = rigid_body_modes(*_problem.V(), _constraint.get(),
                                        _options.near_null_space == "bodies");
  // the Galerkin level's values wait for the first Newton iteration: a product of
  // this Jacobian would be replaced there (each solve starts with a new one), and at
  // n = 2 it cost a numeric product, 4.8 s; its structure (and options) now
  update_mixed_shell(false);
  KSPSetFromOptions(_u_ksp);

  PCSetType(pc, PCSHELL);
  PCShellSetContext(pc, this);
  PCShellSetApply(pc, mixed_shell_apply);
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
    NonlinearSolver* self;
    PCShellGetContext(shell, &self);
    KSPView(self->_q_ksp, viewer);
    KSPView(self->_u_ksp, viewer);
    return 0;
  });
}

void NonlinearSolver::use_vertex_star_smoother(PC u_pc)
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
  std::vector<IS> patches = _constraint ? reduced_star_patches()
                                        : vertex_star_patches(*_problem.V());
  set_star_patches(stars, patches);
  for (IS& patch : patches)
    ISDestroy(&patch);
}

std::vector<IS> NonlinearSolver::reduced_star_patches() const
{
  // the full space's stars renumbered to T^T A T's rows, the dofs the constraint
  // sets left out; the reduced unknowns no star holds (the uniform-axial value)
  // one block more, so that the smoother reaches every unknown
  const fem::FunctionSpace& V = *_problem.V();
  la::Vector<double> numbers(V.dofmap()->index_map, V.dofmap()->index_map_bs());
  const std::vector<std::int64_t> owned = _constraint->reduced_numbers();
  std::copy(owned.begin(), owned.end(), numbers.mutable_array().begin());
  numbers.scatter_fwd();
  std::vector<std::int64_t> local(numbers.array().begin(), numbers.array().end());
  std::vector<IS> patches = vertex_star_patches(V, local);
  PetscInt start, end;
  MatGetOwnershipRangeColumn(_constraint->T(), &start, &end);
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

void NonlinearSolver::update_mixed_shell(bool coarse)
{
  // A changes in place (with the augmented Lagrangian it holds A_gamma); the
  // near-null space goes on each time (GAMG reads it at set-up)
  Mat op = _constraint ? _A_red : _A;
  if (!_coarsening)
    MatSetNearNullSpace(op, _near_null_space);
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

PetscErrorCode NonlinearSolver::mixed_shell_apply(PC pc, Vec r, Vec z)
{
  // upper factorisation: z_q = S^-1 r_q, z_u = A^-1 (r_u - A_uq z_q); with the
  // augmented Lagrangian A_gamma and its share of the constraint rows in r_u
  NonlinearSolver* self;
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
      self->_shell_failure = std::string(prefix ? prefix : "") + ": "
                             + describe_linear_failure(ksp, error);
    }
  };
  {
    SaddleParts parts(r, z, self->_mix_u_in, self->_mix_u_out, self->_mix_q_in,
                      self->_mix_q_out);
    PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
    solve(self->_q_ksp, self->_mix_q_in, self->_mix_q_out);
    agree(); // the product is collective
    if (!failed)
      failed = MatMult(self->coupling_block(0), self->_mix_q_out, self->_mix_u_rhs)
               or VecAYPX(self->_mix_u_rhs, -1.0, self->_mix_u_in)
               or (self->_augmented
                   and self->_augmented->add_constraint_rows(
                       self->_mix_u_rhs, self->_mix_q_in, self->_mix_q_out,
                       self->coupling_block(1), self->_th_blocks[2]));
    agree();
    solve(self->_u_ksp, self->_mix_u_rhs, self->_mix_u_out);
    PetscPopErrorHandler();
  }
  agree();
  if (failed)
    fail_shell_apply(pc, z);
  return 0;
}

} // namespace muscle
