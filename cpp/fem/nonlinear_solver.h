#pragma once

#include "muscle_problem.h"

#include <dolfinx/fem/DirichletBC.h>
#include <dolfinx/la/Vector.h>
#include <array>
#include <memory>
#include <petscsnes.h>
#include <string>
#include <vector>

namespace muscle
{
class AugmentedLagrangian;
class DegreeOneCoarsening;
class DisplacementConstraint;
class FbarCellUnknowns;

/// Newton settings; PETSc command-line options (-snes_*, -ksp_*, -pc_*)
/// override them.
struct NewtonOptions
{
  double rtol = 1e-9;  ///< relative residual reduction
  double atol = 1e-10; ///< absolute residual norm [mN]
  int max_iterations = 25;
  /// "lu" (MUMPS), "gmres-hypre" (BoomerAMG), "gmres-gamg" (with the rigid-body
  /// near-null space), "gmres-schur" (F-bar three-field: the penalty split
  /// through the saddle form, penalty_split.cpp, converges at kappa = 10^4;
  /// Taylor-Hood: its Schur field split) or "gmres-stars" (Taylor-Hood only: that
  /// split with the options of its best measured preconditioner, expand_stars)
  std::string linear_solver = "lu";
  /// GAMG's near-null space: "global", six rigid-body modes for the whole mesh,
  /// or "bodies", six per separately meshed body (mesh_bodies).  Global by
  /// measurement: per body needed more Krylov iterations on every stiff-soft
  /// contrast and on the shoulder (BENCHMARKS.md, "Stiff-soft bodies").
  std::string near_null_space = "global";
  /// GAMG: the tie-reduced matrix carries block size 3 where its unknowns are
  /// whole nodes (DisplacementConstraint::keeps_whole_nodes), so that GAMG
  /// aggregates nodes, not single components.
  bool reduced_blocks = true;
  /// Relative tolerance of the iterative linear solvers (Newton converges
  /// quadratically down to about this reduction per step).
  double linear_rtol = 1e-10;
  /// F-bar elements: Newton on (u, theta, p) with the cell unknowns theta, p
  /// eliminated per cell (FbarCellUnknowns; robust under the stiff penalty),
  /// or -- false -- on u alone with theta = J0(u).  Same converged states.
  bool fbar_cell_unknowns = true;
  /// Largest constraint violation |J0(u) - theta| accepted at convergence.
  double fbar_constraint_tolerance = 1e-10;
  /// PETSc line search, chosen by measurement (BENCHMARKS.md, "Line searches":
  /// of the methods that finish every case, the fewest Newton iterations in
  /// all): "basic", the full Newton step.  Every merit function fails somewhere
  /// under the stiff penalty: a bending or turning nearly incompressible body
  /// (the cantilever, the humerus) raises residual norm and energy along the
  /// straight Newton line, so "cp" creeps there (4x the iterations) and "bt"
  /// stalls, where full steps converge.  "cp" stays best on the fusiform runs
  /// and blocks ("basic" needs 1.16x its iterations there).
  std::string line_search = "basic";
  /// Give up early when the residual norm fell by less than
  /// `stagnation_reduction` (relative) over the last `stagnation_window`
  /// iterations: a line search creeping with tiny steps (seen with cp on
  /// GIANT's travelling wave: 25 iterations losing 1e-6 each) costs a full
  /// max_iterations before the step is cut anyway.  0 disables.
  int stagnation_window = 5;
  double stagnation_reduction = 1e-3;

  /// The names linear_solver, line_search and near_null_space accept.
  static const std::vector<std::string>& linear_solvers();
  static const std::vector<std::string>& line_searches();
  static const std::vector<std::string>& near_null_spaces();
  /// InputError naming the option, its value and what is allowed.
  void validate() const;
};

/// What one nonlinear solve did.
struct NewtonReport
{
  bool converged = false;
  int iterations = 0;
  int linear_iterations = 0;
  std::string reason;                 ///< PETSc's converged/diverged reason
  /// DIVERGED_LINEAR_SOLVE: how the linear solver failed (describe_linear_failure)
  std::string linear_failure;
  std::vector<double> residual_norms; ///< one per Newton iteration, first = initial
  /// the line search's step length lambda of each Newton step (1: the full
  /// Newton step); empty without a line search (trust region)
  std::vector<double> step_lengths;
  KernelStatus kernel;                ///< activation kernel at the last evaluation
  bool non_finite = false;            ///< a residual evaluation produced NaN/inf
};

/// A contribution to the residual and tangent that is no form (contact): added
/// at the current displacement into full-layout PETSc objects by global index
/// (rows and columns of fixed dofs left out: negative indices).
class NonlinearTerm
{
public:
  virtual ~NonlinearTerm() = default;
  virtual void add_residual(Vec F) = 0;
  virtual void add_jacobian(Mat A) = 0;
  /// What to say when Newton fails ("" if nothing).
  virtual std::string diagnosis() const { return ""; }
};

/// Newton's method (PETSc SNES) for the muscle residual with Dirichlet
/// conditions and, optionally, a linear constraint (uniform-axial, tie).  The
/// residual callback refreshes the quadrature-point activation kernels at the
/// evaluation point, so the tangent is exact at every iterate.  A non-finite
/// residual or a kernel without admissible root is reported to SNES as a
/// domain error (the line search then backtracks).
struct NonlinearSolverTestAccess;

class NonlinearSolver
{
  friend struct NonlinearSolverTestAccess; // the tests reach the SNES and its matrix
public:
  NonlinearSolver(MuscleProblem& problem,
                  std::vector<std::shared_ptr<const dolfinx::fem::DirichletBC<double>>> bcs,
                  std::shared_ptr<const DisplacementConstraint> constraint = nullptr,
                  NewtonOptions options = {});

  /// A body of several parts (regions of one mesh with their own material)
  /// sharing one displacement: residuals and Jacobians are summed.
  NonlinearSolver(std::vector<MuscleProblem*> parts,
                  std::vector<std::shared_ptr<const dolfinx::fem::DirichletBC<double>>> bcs,
                  std::shared_ptr<const DisplacementConstraint> constraint = nullptr,
                  NewtonOptions options = {});
  ~NonlinearSolver();
  NonlinearSolver(const NonlinearSolver&) = delete;
  NonlinearSolver& operator=(const NonlinearSolver&) = delete;

  /// Forms added to every residual and Jacobian (external loads, cpp/fem/loads.h):
  /// residuals of the displacement's test space, Jacobians on its trial space
  /// too, each with its own integration domains.
  void add_forms(std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> residuals,
                 std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> jacobians);

  /// A term added to every residual and Jacobian (contact).
  void add_term(std::shared_ptr<NonlinearTerm> term);

  /// Solve from the current displacement; on failure u holds the last iterate
  /// (callers restore their own copy).
  NewtonReport solve();

  /// The last assembled system matrix (reduced if constrained; the penalty split,
  /// which keeps only the reduced soft matrix, forms T^T A T anew on each call).
  Mat system_matrix();

  /// The full tangent at the current displacement (fixed dofs: unit rows), e.g.
  /// for natural frequencies.  InputError with F-bar cell unknowns, whose
  /// tangent is only ever condensed inside a solve.
  Mat assemble_tangent();

  const NewtonOptions& options() const { return _options; }

  /// The line search SNES uses (options().line_search unless a PETSc option
  /// changed it; "" without one, e.g. -snes_type newtontr).
  std::string line_search() const;

  /// The KSP of the displacement system (with F-bar cell unknowns: of the
  /// condensed system), e.g. to change its tolerances between solves.
  KSP linear_solver() const;

  /// Assemble the residual without boundary conditions into `b` (owned +
  /// ghost entries, ghosts accumulated): nodal forces, e.g. reactions.
  void assemble_nodal_forces(dolfinx::la::Vector<double>& b) const;

  /// Activation kernels of every part at the current displacement.
  KernelStatus update_activation();

  /// After the displacement was set from outside (a restored state after a
  /// failed step): F-bar cell unknowns back to theta = J0(u), p = r_0, then the
  /// activation kernels.  Without F-bar the same as update_activation().
  KernelStatus restore_displacement();

  /// Smallest J over the quadrature points of every part's local cells.
  std::pair<double, std::int32_t> min_jacobian_determinant() const;

private:
  // nonlinear_solver.cpp: the linear solver of the Newton steps
  /// -al_gamma, checked against the element, the solver and a constraint
  void read_al_gamma(bool taylor_hood);
  /// "gmres-stars": "gmres-schur" with p-multigrid relaxing Q2 on vertex stars,
  /// BoomerAMG on Q1 (its product lagged 2) and -al_gamma 1, each option the
  /// user gave kept; InputError without Taylor-Hood
  void expand_stars(bool taylor_hood);
  /// InputError for p-multigrid's own options in a run without p-multigrid.
  void refuse_unread_options(bool taylor_hood, bool three_field) const;
  void configure_linear_solver(KSP linear);

  // newton_callbacks.cpp: what SNES calls back (the residual and the Jacobian at
  // an iterate, the convergence test); a non-finite value is a domain error
  static PetscErrorCode residual_callback(SNES, Vec x, Vec F, void* ctx);
  static PetscErrorCode jacobian_callback(SNES, Vec x, Mat J, Mat P, void* ctx);
  /// After each linear solve under -snes_type newtontr, which PETSc 3.18 does not
  /// check: a failed one stops the Newton solve as a linear failure.
  static PetscErrorCode trust_region_linear_check(KSP ksp, Vec, Vec, void* ctx);
  bool _trust_region_linear_failure = false;
  static PetscErrorCode convergence_test(SNES, PetscInt it, PetscReal xnorm,
                                         PetscReal ynorm, PetscReal fnorm,
                                         SNESConvergedReason* reason, void* ctx);
  /// u (and the activation kernels) at the SNES iterate x
  void set_state(Vec x);
  /// _b = the displacement residual at u: every part, the loads and terms,
  /// lifted, Dirichlet rows u - g (owned entries complete)
  void displacement_residual();
  void assemble_full_jacobian();
  /// _A += the loads' and the terms' tangents, identity rows of the Dirichlet
  /// dofs, final assembly; _matrix_norm
  void close_jacobian();
  /// b (owned) += the terms' residuals
  void add_term_residuals(std::span<double> b) const;
  /// |u| of the SNES iterate's displacement block
  double displacement_norm(SNES snes) const;

  /// Forget the last solve's failures (flags, messages, failed preconditioners)
  void start_clean();

  // newton_report.cpp: what a solve did, and why it failed
  NewtonReport outcome(PetscErrorCode error, long inner_iterations_before) const;

  // constraint_reduction.cpp: u = T x
  /// J = T^T A T, rebuilt when A gained nonzeros (contact couples new dofs)
  void reduce(Mat J, bool first);
  /// du (reduced or full owned) -> _work (full, ghosts updated)
  void to_full(Vec du);
  /// x_red += T^T w_owned (or x += w_owned)
  void add_restricted(const dolfinx::la::Vector<double>& w, Vec x);
  /// y = T^T A (T x) with T x already in _work: the reduced product without T^T A T.
  void multiply_reduced(Vec y);

  // fbar_newton.cpp: three-field F-bar (cell unknowns next to u in the SNES vector)
  void create_cell_unknowns();
  /// The SNES iterate from u, with theta = J0(u), p = r_0; then first_full_step
  void start_three_field();
  void set_extended_state(Vec x_ext);
  /// One full Newton step when boundary values moved (see the definition).
  void first_full_step();
  /// After a solve that cp stopped with theta away from J0(u): full Newton steps from
  /// there (see the definition); PETSc's error code.
  PetscErrorCode finish_theta_with_full_steps();
  /// The last SNESSolve converged by the line search alone, theta away from J0(u),
  /// after a nonzero Newton direction.
  bool stopped_short_of_theta() const;
  /// The last Newton direction is zero (only a failed linear solve returns one).
  bool zero_update() const;
  int _full_steps = 0; ///< Newton iterations taken in SNESSolves before the last one
  void extended_residual(Vec F_ext);
  void assemble_three_field_jacobian();
  static PetscErrorCode condensed_solve(PC pc, Vec b, Vec y);
  static PetscErrorCode extended_multiply(Mat J, Vec v, Vec y);
  /// y_cells blocks and the displacement part of an extended vector
  struct Blocks
  {
    std::span<double> u;
    std::vector<std::span<double>> cells;
  };
  Blocks blocks(double* array) const;

  // taylor_hood_newton.cpp: Taylor-Hood, the SNES vector [u | q] with q = (theta, p)
  void create_pressure_unknowns();
  /// u, q (and the activation kernels) at the SNES iterate
  void set_mixed_state(Vec x);
  void mixed_residual(Vec F);
  /// the blocks, their nest and (for a factorisation) its assembled copy
  void assemble_mixed_jacobian();
  /// [u | q] of the current state into x
  void get_mixed_state(Vec x);
  /// The round-off level of the residual at the SNES iterate (without the
  /// safety factor): eps (|A| |u| + |A_mixed| |theta|)
  double mixed_floor(SNES snes) const;
  double _mixed_norm = 0; ///< infinity norm of the mixed Jacobian (the nest's rows)
  /// gmres-schur on the Taylor-Hood system: PCFIELDSPLIT, u and q
  void configure_mixed_split(PC pc);
  /// _schur_pre from A_qq: the q block's Schur complement approximated
  void update_schur_preconditioner();
  Mat _schur_pre = nullptr;
  /// gmres-schur with -fieldsplit_u_pc_type mg or -al_gamma: the field split's
  /// upper block factorisation applied here, with p-multigrid (p_multigrid.h)
  /// on u or the augmented-Lagrangian displacement block
  void configure_mixed_shell(PC pc);
  static PetscErrorCode mixed_shell_apply(PC pc, Vec r, Vec z);
  /// p-multigrid's degree-2 level relaxed on vertex stars
  /// (-fieldsplit_u_mg_levels_pc_type stars; vertex_star.h, star_relaxation.h)
  void use_vertex_star_smoother(PC u_pc);
  /// the vertex stars on T^T A T's rows (under a constraint)
  std::vector<IS> reduced_star_patches() const;
  /// the displacement block's operator (and, with `coarse`, p-multigrid's Galerkin
  /// level) from the current A
  void update_mixed_shell(bool coarse = true);
  /// the augmented-Lagrangian form (-al_gamma), or null
  std::unique_ptr<AugmentedLagrangian> _augmented;
  std::unique_ptr<DegreeOneCoarsening> _coarsening;
  KSP _u_ksp = nullptr; ///< the displacement block's solver (-fieldsplit_u_ options)
  KSP _q_ksp = nullptr; ///< the Schur approximation factored (-fieldsplit_q_ options)
  Vec _mix_u_in = nullptr, _mix_u_out = nullptr; ///< u parts of [u | q] (no own array)
  Vec _mix_q_in = nullptr, _mix_q_out = nullptr; ///< q parts (no own array)
  Vec _mix_u_rhs = nullptr;
  double _al_gamma = 0;      ///< -al_gamma: the penalty over mu at rest; 0: off
  double _shear_modulus = 0; ///< of the law at rest (the Schur approximation's scale)
  /// the coupling blocks under the constraint: T^T A_uq, A_qu T
  void reduce_mixed_blocks(bool first);
  std::array<Mat, 2> _th_reduced{};
  /// the coupling block i (0: A_uq, 1: A_qu) on the unknowns Newton solves for
  Mat coupling_block(int i) const { return _constraint ? _th_reduced[i] : _th_blocks[i]; }
  bool _taylor_hood = false;
  std::unique_ptr<dolfinx::la::Vector<double>> _bq; ///< q residual, with ghosts
  std::array<Mat, 3> _th_blocks{};  ///< dR_u/dq, dR_q/du, dR_q/dq
  /// [[A, A_uq], [A_qu, A_qq]]; A an operator under the augmented Lagrangian
  Mat _J_nest = nullptr;
  Mat _J_mixed = nullptr; ///< the nest assembled (MUMPS only; GMRES takes the nest)
  PetscObjectState _mixed_state = -1; ///< A's nonzero state when _J_mixed was made
  std::vector<double> _q_converged; ///< q of the last converged solve (owned)

  // penalty_split.cpp: "gmres-schur", the preconditioner of the condensed system
  void create_penalty_split(MPI_Comm comm);
  /// The soft matrix, its multigrid and the Schur weights from the Jacobian in _A
  void update_penalty_split();
  /// _sol from _rhs by GMRES on the saddle form; returns the Krylov iterations
  int saddle_solve();
  static PetscErrorCode saddle_multiply(Mat M, Vec v, Vec y);
  static PetscErrorCode penalty_split_apply(PC pc, Vec r, Vec z);
  /// _schur_factor and _schur_sym from the split and d = diag(A_s) (full layout, ghosts)
  void update_sparse_schur(std::span<const double> d);
  /// q <- S^-1 q, approximately (one V-cycle by default; q: the cells' part, local) with
  /// S = I + D_r B diag(A_s)^-1 B^T; false (and _shell_failure) if the solve of
  /// I + C C^T failed (stopped at its iteration limit is an approximation)
  bool sparse_schur_solve(PetscScalar* q);
  Mat _saddle = nullptr;   ///< (du, q) -> (A_s du + B^T q, D_r B du - q), shell
  Vec _saddle_b = nullptr, _saddle_x = nullptr;
  Vec _part_in = nullptr, _part_out = nullptr; ///< the du part of saddle vectors (no own array)
  KSP _soft = nullptr;     ///< one V-cycle on the soft matrix
  Mat _A_soft = nullptr;   ///< K with the cells' stiff penalty share taken out
  Mat _A_soft_red = nullptr; ///< T^T A_soft T when constrained
  PetscObjectState _soft_state = -1; ///< _A's nonzero state when _A_soft was made
  Vec _soft_r = nullptr;
  /// per part and cell: the removed penalty (1 - s_c) K00_c, and sum_j g_j^2 / A_s,jj
  std::vector<std::vector<double>> _split, _schur_h;
  PetscReal _split_ratio = 1; ///< kept penalty / rest of the diagonal (-penalty_split_ratio)
  /// the block factorisation applied (-penalty_split_factorization): "lower" or "upper"
  /// (one V-cycle per Krylov iteration), "full" (two)
  std::string _split_factorization = "lower";
  /// the Schur complement's approximation (-penalty_split_schur): "diagonal", the cells'
  /// diagonal of I + D_r B diag(A_s)^-1 B^T, or "sparse", that matrix itself
  std::string _split_schur = "diagonal";
  Mat _schur_factor = nullptr; ///< C = D_r^1/2 B diag(A_s)^-1/2, cells x full layout
  Mat _schur_sym = nullptr;    ///< I + C C^T
  KSP _schur = nullptr;        ///< one V-cycle on _schur_sym (-schur_ options)
  Vec _schur_rhs = nullptr, _schur_w = nullptr;
  /// diag(A_s), full layout with ghosts: kept, since the soft solve's to_full overwrites
  /// _work before the Schur solve needs it
  std::vector<double> _soft_diagonal;

  std::vector<MuscleProblem*> _parts;
  MuscleProblem& _problem; ///< the first part: displacement, space, mesh
  std::vector<std::shared_ptr<const dolfinx::fem::DirichletBC<double>>> _bcs;
  std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> _extra_residuals,
      _extra_jacobians;
  std::vector<std::shared_ptr<NonlinearTerm>> _terms;
  Vec _term_F = nullptr;
  PetscObjectState _reduced_state = -1;
  std::shared_ptr<const DisplacementConstraint> _constraint;
  NewtonOptions _options;

  SNES _snes = nullptr;
  /// full Jacobian (Taylor-Hood's displacement block; A_gamma once the augmented
  /// Lagrangian has added its cells' terms)
  Mat _A = nullptr;
  Mat _A_red = nullptr;   ///< T^T A T when constrained (the penalty split forms none)
  Vec _full_tmp = nullptr; ///< full layout, owned part: A (T x) of multiply_reduced
  Mat _ptap = nullptr;    ///< T^T A T recomputed after A gained nonzeros, copied into _A_red
  int _reduced_bs = 1;    ///< block size of _A_red (GAMG: 3 on whole nodes)
  MatNullSpace _near_null_space = nullptr; ///< rigid-body modes of the matrix GAMG sees
  Vec _x = nullptr;       ///< SNES iterate (a copy of u's owned part, or reduced)
  Vec _u_petsc = nullptr; ///< wraps u's owned part (unconstrained case)
  Vec _b_petsc = nullptr; ///< wraps _b (full residual)
  Vec _F_full = nullptr;  ///< owned part of _b as a plain vector (for T^T b)
  dolfinx::la::Vector<double> _b;
  KernelStatus _last_kernel;
  double _matrix_norm = 0; ///< infinity norm of the last Jacobian (NaN: not finite)
  bool _non_finite = false;
  bool _stagnated = false;
  /// the convergence test's verdict on the last iterate it saw: PETSc can stop a
  /// solve as converged without asking it (the cp line search on a zero direction)
  SNESConvergedReason _test_verdict = SNES_CONVERGED_ITERATING;
  /// which inner solve of a shell preconditioner failed, and how (stop messages)
  std::string _shell_failure;
  std::vector<double> _norms; ///< residual norms of the current solve
  std::vector<double> _step_lengths; ///< line-search lambdas of the current solve

  std::vector<std::unique_ptr<FbarCellUnknowns>> _cell_unknowns;
  Vec _x_ext = nullptr;     ///< three-field: SNES iterate (u part, then every part's cells)
  Mat _J_ext = nullptr;     ///< three-field: the extended Jacobian (shell)
  KSP _inner = nullptr;     ///< three-field: the linear solver of the condensed system
  Vec _rhs = nullptr, _sol = nullptr, _tmp = nullptr; ///< displacement-part work vectors
  dolfinx::la::Vector<double> _work, _work2; ///< full displacement, with ghosts
  double _constraint_violation = 0;
  long _inner_iterations = 0;
  PetscErrorCode _linear_error = 0; ///< a PETSc error in the last condensed solve
};

} // namespace muscle
