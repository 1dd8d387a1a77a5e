// The three-field Newton of the F-bar element (theta, p eliminated per cell)
// against the displacement Newton on the same element: the converged states
// must agree (they solve the same discrete equations), the three-field
// iteration must converge quadratically -- which fails if the condensation,
// the recovery of dtheta, dp or the extended Jacobian is off -- and it must
// need fewer iterations under the preset penalty, the reason it exists.
#include <common/errors.h>
#include <fem/constraints/boundary.h>
#include <fem/elements/fbar_unknowns.h>
#include <fem/elements/muscle_problem.h>
#include <fem/linear/penalty_split.h>
#include <fem/newton/fbar_formulation.h>
#include <fem/newton/nonlinear_solver.h>
#include <fem/constraints/uniform_constraint.h>
#include <material/parameters.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <tuple>
#include <dolfinx/mesh/generation.h>
#include <dolfinx/mesh/utils.h>
#include <gtest/gtest.h>
#include <xtensor/xbuilder.hpp>

using namespace muscle;
using namespace dolfinx;

namespace
{
struct Outcome
{
  std::vector<double> u;
  NewtonReport report; ///< of the last step
  int total_iterations = 0;
};

/// A block clamped at z = 0, its top (z = 1.5) either pulled up (prescribed
/// axial displacement `lift`) or free to move as one (the uniform-axial
/// constraint, the fusiform "free" case); fibres along z.
struct Block
{
  std::unique_ptr<MuscleProblem> problem;
  std::vector<std::shared_ptr<const fem::DirichletBC<double>>> bcs;
  std::shared_ptr<UniformDisplacementConstraint> constraint;
  std::shared_ptr<fem::Constant<double>> lift;
};

/// `kappa` > 0 replaces the preset incompressibility penalty.
Block make_block(Model model, bool constrained, double kappa = 0)
{
  auto mesh = std::make_shared<mesh::Mesh>(mesh::create_box(
      MPI_COMM_WORLD, {{{0, 0, 0}, {1, 1, 1.5}}}, {2, 2, 3}, mesh::CellType::hexahedron,
      mesh::GhostMode::shared_facet));
  Discretisation d;
  d.fbar = true;
  Block block;
  ParameterSet parameters(model);
  if (kappa > 0)
    parameters.set("kappa", kappa);
  block.problem = std::make_unique<MuscleProblem>(mesh, parameters, d);
  block.problem->set_fibre({0.1, 0.0, 1.0});

  const int fdim = 2;
  mesh->topology_mutable().create_connectivity(fdim, 3);
  auto on = [&](double z)
  {
    return mesh::locate_entities_boundary(
        *mesh, fdim,
        [z](const xt::xtensor<double, 2>& x) -> xt::xtensor<bool, 1>
        {
          xt::xtensor<bool, 1> marked = xt::zeros<bool>({x.shape(1)});
          for (std::size_t i = 0; i < x.shape(1); ++i)
            marked(i) = std::abs(x(2, i) - z) < 1e-10;
          return marked;
        });
  };
  auto V = block.problem->V();
  block.bcs = {clamp(V, on(0.0))};
  block.lift = std::make_shared<fem::Constant<double>>(0.0);
  auto zero = std::make_shared<fem::Constant<double>>(0.0);
  if (constrained)
  {
    block.bcs.push_back(prescribe_component(V, on(1.5), 0, zero));
    block.bcs.push_back(prescribe_component(V, on(1.5), 1, zero));
    block.constraint = std::make_shared<UniformDisplacementConstraint>(
        *V, component_dofs(*V, on(1.5), 2));
  }
  else
    block.bcs.push_back(prescribe_component(V, on(1.5), 2, block.lift));
  return block;
}

/// The block activated in `steps` equal load steps (the displacement Newton
/// needs several under the preset penalty).
Outcome solve(Model model, bool three_field, const std::string& line_search, bool constrained,
              int steps, double kappa = 0)
{
  Block block = make_block(model, constrained, kappa);
  MuscleProblem& problem = *block.problem;
  NewtonOptions options;
  options.fbar_cell_unknowns = three_field;
  options.line_search = line_search;
  options.stagnation_window = 0;
  options.max_iterations = 60;
  NonlinearSolver solver(problem, block.bcs, block.constraint, options);
  Outcome o;
  int iterations = 0;
  for (int k = 1; k <= steps; ++k)
  {
    problem.set_time_factor(double(k) / steps);
    block.lift->value = {0.05 * k / steps};
    o.report = solver.solve();
    iterations += o.report.iterations;
    if (!o.report.converged)
      break;
  }
  o.total_iterations = iterations;
  o.u.assign(problem.u()->x()->array().begin(), problem.u()->x()->array().end());
  return o;
}

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b)
{
  double d = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

double max_abs(const std::vector<double>& a)
{
  double d = 0;
  for (double x : a)
    d = std::max(d, std::abs(x));
  return d;
}

/// Smallest ratio log(r_{k+1}) / log(r_k) over the steps with r_k < 1e-2 r_0 that
/// end above round-off (1e-11 r_0 for the stiff penalty): 2 for quadratic convergence.
double convergence_order(const std::vector<double>& r)
{
  double order = 10;
  for (std::size_t k = 1; k + 1 < r.size(); ++k)
  {
    const double a = r[k] / r[0], b = r[k + 1] / r[0];
    if (a < 1e-2 and b > 1e-11)
      order = std::min(order, std::log(b) / std::log(a));
  }
  return order;
}

/// GMRES + GAMG, no stagnation abort: the multigrid tests' solver.  The line
/// search cp: these tests run one Newton solve without the stepper, and the
/// default basic's first full step on the free block overshoots PETSc's
/// divergence limit (a run would cut the step back; not what is tested here).
NewtonOptions multigrid_options()
{
  NewtonOptions options;
  options.line_search = "cp";
  options.linear_solver = "gmres-gamg";
  options.linear_rtol = 1e-8;
  options.stagnation_window = 0;
  return options;
}

struct Case
{
  Model model;
  bool constrained;
  const char* line_search;
};

class FbarNewton : public ::testing::TestWithParam<Case>
{
};
} // namespace

TEST_P(FbarNewton, ConvergesQuadraticallyToTheDisplacementNewtonsState)
{
  const Case c = GetParam();
  // the three-field Newton in one step, the displacement Newton in forty
  const Outcome mixed = solve(c.model, true, c.line_search, c.constrained, 1);
  const Outcome plain = solve(c.model, false, "cp", c.constrained, 40);
  ASSERT_TRUE(mixed.report.converged) << mixed.report.reason;
  ASSERT_TRUE(plain.report.converged) << plain.report.reason;
  const double scale = max_abs(plain.u);
  EXPECT_GT(scale, 1e-3);
  EXPECT_LT(max_abs_diff(mixed.u, plain.u), 1e-8 * scale);
  const double order = convergence_order(mixed.report.residual_norms);
  EXPECT_GT(order, 1.7);
  EXPECT_LT(mixed.total_iterations, plain.total_iterations);
  std::printf("%s %s %s: %d Newton iterations in one step (displacement Newton: %d in forty), "
              "order %.2f, |u - u_displacement| = %.1e |u|\n",
              to_string(c.model).c_str(), c.constrained ? "free" : "pulled", c.line_search,
              mixed.total_iterations, plain.total_iterations, order,
              max_abs_diff(mixed.u, plain.u) / scale);
}

INSTANTIATE_TEST_SUITE_P(
    Models, FbarNewton,
    ::testing::Values(Case{Model("combi"), false, "cp"}, Case{Model("combi"), true, "cp"},
                      Case{Model("combi"), false, "bt"}, Case{Model("giant"), true, "cp"},
                      Case{Model("wkm"), false, "cp"}, Case{Model("ble"), true, "bt"}),
    [](const auto& info)
    {
      return to_string(info.param.model) + (info.param.constrained ? "_free_" : "_pulled_")
             + info.param.line_search;
    });

// The line search cp declares convergence itself, without the convergence test,
// where dot(F, dx) is below its atol.  F-bar's constraint rows are tiny in that
// product, so it can do so while theta is still away from J0(u), which the
// convergence test refuses (seen at kappa = 10^4, PenaltySplit's free block).
// Forced here at every Newton iteration by an atol no direction passes: the solve
// must go on by full steps to the state the default line search reaches, not stop
// with the constraint violated (which it did: 8.6e-3 after the first full step).
TEST(FbarNewtonLineSearch, CpStoppingWithThetaAwayFromJ0IsFinishedByFullSteps)
{
  auto solve_block = [](const char* line_search_atol)
  {
    Block block = make_block(Model("combi"), false);
    NewtonOptions options;
    options.line_search = line_search_atol ? "cp" : "basic";
    options.stagnation_window = 0;
    if (line_search_atol)
      PetscOptionsSetValue(nullptr, "-snes_linesearch_atol", line_search_atol);
    NonlinearSolver solver(*block.problem, block.bcs, block.constraint, options);
    PetscOptionsClearValue(nullptr, "-snes_linesearch_atol");
    block.problem->set_time_factor(1.0);
    block.lift->value = {0.05}; // a moved boundary: one full step first, theta lags J0(u)
    const NewtonReport report = solver.solve();
    const std::span<const double> u = block.problem->u()->x()->array();
    return std::pair{report, std::vector<double>(u.begin(), u.end())};
  };
  const auto [stopped, u] = solve_block("1e300");
  const auto [full, reference] = solve_block(nullptr);
  ASSERT_TRUE(full.converged) << full.reason;
  EXPECT_TRUE(stopped.converged) << stopped.reason;
  EXPECT_LT(max_abs_diff(u, reference), 1e-8 * max_abs(reference));
  // every Newton iteration counted across the stop (cp took none before it here)
  EXPECT_EQ(stopped.iterations, full.iterations);
  std::printf("cp stopped at every iteration: %d Newton iterations, basic %d\n",
              stopped.iterations, full.iterations);
}

// A failed linear solve must fail only that Newton solve: the stepper cuts the
// step and tries again with the same solver (PETSc keeps a shell
// preconditioner's failure flag until it is cleared).  The failure is forced
// (one GMRES iteration of the production multigrid); the second solve runs the
// same KSP preconditioned by an exact factorisation, so that its convergence
// has a margin on any CPU and only the recovery is tested.
TEST(FbarNewtonRecovery, SolvesAgainAfterAFailedLinearSolve)
{
  for (bool constrained : {false, true})
  {
    Block block = make_block(Model("combi"), constrained);
    MuscleProblem& problem = *block.problem;
    NonlinearSolver solver(problem, block.bcs, block.constraint, multigrid_options());
    problem.set_time_factor(1.0);
    block.lift->value = {0.05};
    KSP linear = solver.linear_solver();
    KSPSetTolerances(linear, 1e-8, 1e-30, PETSC_DEFAULT, 1); // one GMRES iteration: fails
    const NewtonReport failed = solver.solve();
    EXPECT_FALSE(failed.converged) << constrained;
    EXPECT_NE(failed.reason.find("DIVERGED_LINEAR_SOLVE"), std::string::npos) << failed.reason;
    EXPECT_NE(failed.linear_failure.find("DIVERGED_ITS"), std::string::npos)
        << failed.linear_failure;
    // back to the start, as the stepper does after a failure
    std::fill(problem.u()->x()->mutable_array().begin(),
              problem.u()->x()->mutable_array().end(), 0.0);
    solver.restore_displacement();
    PC pc;
    KSPGetPC(linear, &pc);
    PCSetType(pc, PCLU);
    PCFactorSetMatSolverType(pc, MATSOLVERMUMPS);
    KSPSetTolerances(linear, 1e-10, 1e-30, PETSC_DEFAULT, 50);
    const NewtonReport report = solver.solve();
    EXPECT_TRUE(report.converged) << report.reason << (constrained ? " (free)" : " (pulled)");
    EXPECT_TRUE(report.linear_failure.empty()) << report.linear_failure;
    // the same state as the direct solver's
    const Outcome lu = solve(Model("combi"), true, "cp", constrained, 1);
    const std::vector<double> u(problem.u()->x()->array().begin(),
                                problem.u()->x()->array().end());
    EXPECT_LT(max_abs_diff(u, lu.u), 1e-6 * max_abs(lu.u));
  }
}

// PETSc 3.18's trust region (-snes_type newtontr) never checks its linear solve: a
// failed one gave a direction it shrank the region around until DIVERGED_TR_DELTA,
// and the stop advised a smaller time step.  It must fail as a linear solve, named,
// in the three-field Newton and the displacement Newton alike.  (A radius so large
// that GMRES is not stopped at it: a Krylov solve cut at the radius is the method's.)
TEST(FbarNewtonRecovery, TrustRegionReportsAFailedLinearSolve)
{
  for (bool three_field : {true, false})
  {
    Block block = make_block(Model("combi"), false);
    NewtonOptions options = multigrid_options();
    options.fbar_cell_unknowns = three_field;
    PetscOptionsSetValue(nullptr, "-snes_type", "newtontr");
    PetscOptionsSetValue(nullptr, "-snes_tr_delta0", "1e10");
    NonlinearSolver solver(*block.problem, block.bcs, block.constraint, options);
    PetscOptionsClearValue(nullptr, "-snes_type");
    PetscOptionsClearValue(nullptr, "-snes_tr_delta0");
    block.problem->set_time_factor(1.0);
    block.lift->value = {0.05};
    KSPSetTolerances(solver.linear_solver(), 1e-8, 1e-30, PETSC_DEFAULT, 1);
    const NewtonReport report = solver.solve();
    EXPECT_FALSE(report.converged) << three_field;
    EXPECT_NE(report.reason.find("DIVERGED_LINEAR_SOLVE"), std::string::npos)
        << report.reason;
    EXPECT_NE(report.linear_failure.find("DIVERGED_ITS"), std::string::npos)
        << report.linear_failure;
  }
}

// Under the uniform-axial constraint GAMG works on the reduced unknowns: it must
// get the rigid-body modes there too (without them: 479 instead of 110 Krylov
// iterations per Newton iteration for the free fusiform muscle, n = 2).  The
// reduced axial translation lies in the span of the near-null space handed over,
// and the multigrid solve reaches the direct solver's state.
//
// At the preset penalty (kappa = 1000) GAMG is a weak two-level method on this
// 100-unknown block: 200-300 Krylov iterations per Newton iteration, and on some
// CPUs a GMRES breakdown.  At kappa = 10 (the penalty of the musculoskeletal
// scenes) it needs about 22, far from the 2,000 cap, so the test hangs on the
// modes and not on round-off.
TEST(FbarNewtonMultigrid, FreeBlockKeepsTheRigidBodyModes)
{
  const double kappa = 10;
  Block block = make_block(Model("combi"), true, kappa);
  MuscleProblem& problem = *block.problem;
  NonlinearSolver solver(problem, block.bcs, block.constraint, multigrid_options());
  problem.set_time_factor(1.0);
  const NewtonReport report = solver.solve();
  ASSERT_TRUE(report.converged) << report.reason;
  EXPECT_LT(report.linear_iterations, 100 * report.iterations)
      << "GAMG lost its margin: " << report.linear_iterations << " Krylov iterations in "
      << report.iterations << " Newton iterations";

  MatNullSpace ns = nullptr;
  MatGetNearNullSpace(solver.system_matrix(), &ns);
  ASSERT_NE(ns, nullptr) << "no near-null space on the reduced matrix";
  PetscBool has_constant;
  PetscInt n;
  const Vec* vecs;
  MatNullSpaceGetVecs(ns, &has_constant, &n, &vecs);
  ASSERT_EQ(n, 6);
  // the axial translation, reduced by the constraint's own restriction
  auto V = problem.V();
  la::Vector<double> full(V->dofmap()->index_map, V->dofmap()->index_map_bs());
  for (std::size_t i = 2; i < full.array().size(); i += 3)
    full.mutable_array()[i] = 1.0;
  Vec e = block.constraint->create_reduced_vector(), rest;
  block.constraint->restrict_to(full, e);
  VecDuplicate(e, &rest);
  VecCopy(e, rest);
  for (PetscInt i = 0; i < n; ++i)
  {
    PetscScalar d;
    VecDot(e, vecs[i], &d);
    VecAXPY(rest, -d, vecs[i]);
    for (PetscInt j = 0; j < n; ++j)
    {
      PetscScalar g;
      VecDot(vecs[i], vecs[j], &g);
      EXPECT_NEAR(g, i == j ? 1.0 : 0.0, 1e-12) << i << " " << j;
    }
  }
  PetscReal e_norm, rest_norm;
  VecNorm(e, NORM_2, &e_norm);
  VecNorm(rest, NORM_2, &rest_norm);
  EXPECT_LT(rest_norm, 1e-12 * e_norm);
  VecDestroy(&e);
  VecDestroy(&rest);

  const Outcome lu = solve(Model("combi"), true, "cp", true, 1, kappa);
  ASSERT_TRUE(lu.report.converged) << lu.report.reason;
  const std::vector<double> u(problem.u()->x()->array().begin(),
                              problem.u()->x()->array().end());
  EXPECT_LT(max_abs_diff(u, lu.u), 1e-7 * max_abs(lu.u));
}

// The penalty split ("gmres-schur", penalty_split.cpp): multigrid sees only a soft share
// of each cell's penalty, the rest goes through the saddle form's diagonal Schur
// complement.  At kappa = 10^4 GAMG on the whole matrix fails on this block (GMRES
// reaches its cap; 31 Krylov iterations per Newton iteration at kappa = 100); the split
// must converge there too -- 181 (lifted) and 113 (free) per Newton iteration with the full
// factorisation, 30 at kappa = 100 -- and reach the direct solver's state, whichever block
// factorisation (-penalty_split_factorization) preconditions it.
class PenaltySplitSolve : public ::testing::TestWithParam<std::tuple<bool, const char*>>
{
};

/// Sets a PETSc option for a scope (also when an assertion leaves it early).
struct ScopedOption
{
  ScopedOption(const char* name, const char* value) : _name(name)
  {
    PetscOptionsSetValue(nullptr, name, value);
  }
  ~ScopedOption() { PetscOptionsClearValue(nullptr, _name); }
  ScopedOption(const ScopedOption&) = delete;
  ScopedOption& operator=(const ScopedOption&) = delete;
private:
  const char* _name;
};

struct Factorisation : ScopedOption
{
  explicit Factorisation(const char* name) : ScopedOption("-penalty_split_factorization", name)
  {
  }
};

NewtonOptions split_options()
{
  NewtonOptions options = multigrid_options();
  options.linear_solver = "gmres-schur";
  return options;
}

/// The block lifted (or, constrained, moved) by 0.05, solved by `solver`.
NewtonReport solve_split(Block& block, NonlinearSolver& solver)
{
  block.problem->set_time_factor(1.0);
  block.lift->value = {0.05};
  return solver.solve();
}

/// The same with the penalty split.
NewtonReport solve_split(Block& block)
{
  NonlinearSolver solver(*block.problem, block.bcs, block.constraint, split_options());
  return solve_split(block, solver);
}

/// The penalty split's Newton report on the lifted block at kappa, by factorisation.
NewtonReport split_report(const char* factorization, double kappa)
{
  const Factorisation chosen(factorization);
  Block block = make_block(Model("combi"), false, kappa);
  const NewtonReport report = solve_split(block);
  EXPECT_TRUE(report.converged) << factorization << ": " << report.reason;
  return report;
}

TEST_P(PenaltySplitSolve, ConvergesUnderTheStiffPenaltyToTheDirectSolversState)
{
  const auto [constrained, factorization] = GetParam();
  const Factorisation chosen(factorization);
  for (const double kappa : {100.0, 10000.0})
  {
    Block block = make_block(Model("combi"), constrained, kappa);
    const NewtonReport report = solve_split(block);
    ASSERT_TRUE(report.converged) << "kappa " << kappa << ": " << report.reason;
    EXPECT_LT(report.linear_iterations, 300 * report.iterations)
        << "kappa " << kappa << ": " << report.linear_iterations << " Krylov iterations in "
        << report.iterations << " Newton iterations";
    const Outcome lu = solve(Model("combi"), true, "cp", constrained, 1, kappa);
    ASSERT_TRUE(lu.report.converged) << lu.report.reason;
    const auto& x = block.problem->u()->x()->array();
    const std::vector<double> u(x.begin(), x.end());
    EXPECT_LT(max_abs_diff(u, lu.u), 1e-7 * max_abs(lu.u)) << "kappa " << kappa;
  }
}

INSTANTIATE_TEST_SUITE_P(LiftedAndFree, PenaltySplitSolve,
                         ::testing::Combine(::testing::Values(false, true),
                                            ::testing::Values("lower", "upper", "full")),
                         [](const auto& info)
                         {
                           return std::string(std::get<0>(info.param) ? "free_" : "lifted_")
                                  + std::get<1>(info.param);
                         });

namespace muscle
{
struct NonlinearSolverTestAccess
{
  static SNES snes(NonlinearSolver& solver) { return solver._snes; }
  /// the penalty split that solves the condensed system
  static PenaltySplit& split(const NonlinearSolver& solver)
  {
    const auto* fbar = dynamic_cast<const FbarFormulation*>(solver._formulation.get());
    if (!fbar or !fbar->penalty_split())
      throw std::logic_error("the solver has no penalty split");
    return const_cast<PenaltySplit&>(*fbar->penalty_split());
  }
  static bool sparse_schur_solve(NonlinearSolver& solver, std::vector<double>& q)
  {
    return split(solver).sparse_schur_solve(q.data());
  }
  /// the cells' unknowns q of the saddle form
  static std::size_t cells(const NonlinearSolver& solver)
  {
    std::size_t count = 0;
    for (const auto& part : split(solver).removed_shares())
      count += part.size();
    return count;
  }
  /// S q with S = I + D_r B diag(A_s)^-1 B^T formed cell by cell from the cells'
  /// linearisation, their removed penalty shares and the soft matrix's diagonal (one rank)
  static std::vector<double> schur_product(NonlinearSolver& solver, const std::vector<double>& q)
  {
    const PenaltySplit& s = split(solver);
    Vec d;
    MatCreateVecs(s.soft_matrix(), &d, nullptr);
    MatGetDiagonal(s.soft_matrix(), d);
    const PetscScalar* diagonal;
    VecGetArrayRead(d, &diagonal);
    std::vector<double> w(solver._system.b().array().size(), 0.0), Sq;
    for (int pass = 0; pass < 2; ++pass)
    {
      std::size_t k = 0;
      for (std::size_t part = 0; part < s.cells().size(); ++part)
      {
        const FbarCellUnknowns& cells = *s.cells()[part];
        const auto& data = cells.linearisation();
        for (std::size_t c = 0; c < data.K00.size(); ++c, ++k)
        {
          double Bw = 0;
          for (std::size_t j = 0; j < data.n; ++j)
          {
            const std::int32_t dof = cells.cell_dofs()[c * data.n + j];
            if (cells.fixed()[dof])
              continue;
            if (pass == 0)
              w[dof] += data.g[c * data.n + j] * q[k];
            else
              Bw += data.g[c * data.n + j] * w[dof] / diagonal[dof];
          }
          if (pass == 1)
            Sq.push_back(q[k] + s.removed_shares()[part][c] * Bw);
        }
      }
    }
    VecRestoreArrayRead(d, &diagonal);
    VecDestroy(&d);
    return Sq;
  }
  /// the cells whose penalty is partly removed from the soft matrix
  static std::size_t split_cells(const NonlinearSolver& solver)
  {
    std::size_t count = 0;
    for (const auto& part : split(solver).removed_shares())
      count += std::count_if(part.begin(), part.end(), [](double r) { return r > 0; });
    return count;
  }
};
} // namespace muscle

namespace
{
/// J v of a solver's SNES matrix at x (the Jacobian assembled there first).
std::vector<double> jacobian_product(NonlinearSolver& solver, Vec x, Vec v)
{
  SNES snes = NonlinearSolverTestAccess::snes(solver);
  Mat J;
  SNESGetJacobian(snes, &J, nullptr, nullptr, nullptr);
  SNESComputeJacobian(snes, x, J, J);
  Vec y;
  VecDuplicate(v, &y);
  MatMult(J, v, y);
  PetscInt n;
  VecGetLocalSize(y, &n);
  const PetscScalar* a;
  VecGetArrayRead(y, &a);
  std::vector<double> out(a, a + n);
  VecRestoreArrayRead(y, &a);
  VecDestroy(&y);
  return out;
}
} // namespace

// Under a constraint the penalty split keeps only T^T A_s T; the extended Jacobian's
// product (SNES's matrix, which the backtracking line search takes for its initial slope)
// is then T^T (A (T v)).  It must equal the product through the assembled T^T A T that
// the multigrid solver keeps, at the same active, deformed state.
TEST(PenaltySplitConstrained, JacobianProductEqualsTheAssembledReducedMatrix)
{
  const double kappa = 1000;
  Block block = make_block(Model("combi"), true, kappa);
  NonlinearSolver split(*block.problem, block.bcs, block.constraint, split_options());
  block.problem->set_time_factor(1.0);
  const NewtonReport report = split.solve();
  ASSERT_TRUE(report.converged) << report.reason;
  NonlinearSolver assembled(*block.problem, block.bcs, block.constraint, multigrid_options());

  Vec x, v;
  SNESGetSolution(NonlinearSolverTestAccess::snes(split), &x);
  VecDuplicate(x, &v);
  PetscInt n, first;
  VecGetLocalSize(v, &n);
  VecGetOwnershipRange(v, &first, nullptr);
  PetscScalar* a;
  VecGetArray(v, &a);
  for (PetscInt i = 0; i < n; ++i)
    a[i] = std::sin(1.0 + first + i); // every entry, u and the cells' unknowns
  VecRestoreArray(v, &a);
  const std::vector<double> expected = jacobian_product(assembled, x, v);
  const std::vector<double> product = jacobian_product(split, x, v);
  VecDestroy(&v);
  ASSERT_EQ(product.size(), expected.size());
  EXPECT_LT(max_abs_diff(product, expected), 1e-10 * max_abs(expected));

  // and the reduced matrix is formed on request, of the reduced size
  Mat K = split.system_matrix();
  ASSERT_NE(K, nullptr);
  PetscInt rows, reduced;
  MatGetSize(K, &rows, nullptr);
  MatGetSize(block.constraint->T(), nullptr, &reduced);
  EXPECT_EQ(rows, reduced);
}

// Each factorisation is what is applied: right preconditioning reaches the same state with
// any of them, to the linear tolerance.  A serial run is deterministic, so an ignored option
// would repeat the lower factor's Newton history bit for bit; each factor's inexact
// directions leave their own.  (Krylov totals are no test: on one CPU lower and upper both
// took 1080 on this block at kappa = 10^4, from different per-solve counts.)
TEST(PenaltySplitFactorisation, EachIsApplied)
{
  const NewtonReport lower = split_report("lower", 10000.0);
  const NewtonReport upper = split_report("upper", 10000.0);
  const NewtonReport full = split_report("full", 10000.0);
  EXPECT_NE(lower.residual_norms, upper.residual_norms);
  EXPECT_NE(lower.residual_norms, full.residual_norms);
  EXPECT_NE(upper.residual_norms, full.residual_norms);
}

namespace
{
/// The split solver given `option value` must refuse it with an InputError naming `allowed`.
void expect_input_error(const char* option, const char* value, const std::string& allowed)
{
  const ScopedOption chosen(option, value);
  Block block = make_block(Model("combi"), false, 1000.0);
  try
  {
    NonlinearSolver solver(*block.problem, block.bcs, block.constraint, split_options());
    ADD_FAILURE() << "no error for " << option << " " << value;
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("allowed are " + allowed), std::string::npos)
        << e.what();
  }
}
} // namespace

TEST(PenaltySplitInput, AnUnknownFactorisationIsAnInputError)
{
  expect_input_error("-penalty_split_factorization", "diagonal", "lower, upper, full");
}

// The sparse Schur approximation (-penalty_split_schur sparse) S = I + D_r B diag(A_s)^-1 B^T
// is solved through the assembled product I + C C^T, C = D_r^1/2 B diag(A_s)^-1/2, and a
// rescaling (penalty_split.cpp).  Solved exactly (LU) it must invert S formed here cell by
// cell, at an active state where most cells have a share removed.
TEST(PenaltySplitSparseSchur, InvertsTheCellwiseComplement)
{
  int ranks;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  if (ranks > 1)
    GTEST_SKIP() << "the cell-by-cell product is serial";
  const ScopedOption sparse("-penalty_split_schur", "sparse");
  const ScopedOption exact("-schur_pc_type", "lu");
  Block block = make_block(Model("combi"), false, 10000.0);
  NonlinearSolver solver(*block.problem, block.bcs, block.constraint, split_options());
  const NewtonReport report = solve_split(block, solver);
  ASSERT_TRUE(report.converged) << report.reason;
  // the split, the soft matrix and the cells' g are those of the last Jacobian
  ASSERT_GT(NonlinearSolverTestAccess::split_cells(solver), 0u);

  const std::size_t cells = NonlinearSolverTestAccess::cells(solver);
  ASSERT_EQ(cells, 2u * 2u * 3u);
  std::vector<double> v(cells), q(cells);
  for (std::size_t k = 0; k < cells; ++k)
    v[k] = q[k] = std::sin(1.0 + k);
  ASSERT_TRUE(NonlinearSolverTestAccess::sparse_schur_solve(solver, q));
  const std::vector<double> Sq = NonlinearSolverTestAccess::schur_product(solver, q);
  ASSERT_EQ(Sq.size(), cells);
  EXPECT_LT(max_abs_diff(Sq, v), 1e-10 * max_abs(v));
  EXPECT_GT(max_abs_diff(q, v), 1e-3 * max_abs(v)) << "S is not the identity here";
}

TEST(PenaltySplitInput, AnUnknownSchurApproximationIsAnInputError)
{
  expect_input_error("-penalty_split_schur", "exact", "diagonal, sparse");
}
