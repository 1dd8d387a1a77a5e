// A solver's PETSc options are its own: the defaults its linear solver sets
// (gmres-stars: -al_gamma, p-multigrid on u, Chebyshev on q) never reach the
// process's options database, so a second solver in the same process is set up
// and solved with its own defaults, while the options a user gave the process
// still reach both.
#include <fem/constraints/boundary.h>
#include <fem/elements/muscle_problem.h>
#include <fem/newton/nonlinear_solver.h>
#include <material/parameters.h>

#include <cmath>
#include <dolfinx/mesh/generation.h>
#include <dolfinx/mesh/utils.h>
#include <gtest/gtest.h>
#include <petscksp.h>
#include <string>

using namespace muscle;
using namespace dolfinx;

namespace
{
/// A Taylor-Hood block (Q2-Q1), clamped at z = 0, activated.
struct Body
{
  std::unique_ptr<MuscleProblem> problem;
  DirichletBCs bcs;
};

Body make_body()
{
  auto mesh = std::make_shared<mesh::Mesh>(mesh::create_box(
      MPI_COMM_WORLD, {{{0, 0, 0}, {1, 1, 2}}}, {1, 1, 2}, mesh::CellType::hexahedron,
      mesh::GhostMode::shared_facet));
  Discretisation d;
  d.degree = 2;
  d.taylor_hood = true;
  ParameterSet parameters(Model("combi"));
  parameters.set("kappa", 3.0);
  Body b;
  b.problem = std::make_unique<MuscleProblem>(mesh, parameters, d);
  b.problem->set_fibre({0, 0, 1});
  b.problem->set_time_factor(0.5);
  mesh->topology_mutable().create_connectivity(2, 3);
  const std::vector<std::int32_t> bottom = mesh::locate_entities_boundary(
      *mesh, 2,
      [](const xt::xtensor<double, 2>& x) -> xt::xtensor<bool, 1>
      {
        xt::xtensor<bool, 1> marked = xt::zeros<bool>({x.shape(1)});
        for (std::size_t i = 0; i < x.shape(1); ++i)
          marked(i) = std::abs(x(2, i)) < 1e-10;
        return marked;
      });
  b.bcs = {clamp(b.problem->V(), bottom)};
  return b;
}

NewtonOptions with_solver(const char* name)
{
  NewtonOptions options;
  options.linear_solver = name;
  options.linear_rtol = 1e-8;
  return options;
}

bool in_process_options(const char* name)
{
  PetscBool given = PETSC_FALSE;
  PetscOptionsHasName(nullptr, nullptr, name, &given);
  return given;
}

std::string pc_type(KSP ksp)
{
  PC pc;
  KSPGetPC(ksp, &pc);
  PCType type;
  PCGetType(pc, &type);
  return type ? type : "";
}

/// The preconditioner types of a PCFIELDSPLIT's two blocks (after its set-up).
std::pair<std::string, std::string> split_blocks(KSP ksp)
{
  PC pc;
  KSPGetPC(ksp, &pc);
  PetscInt n = 0;
  KSP* blocks = nullptr;
  PCFieldSplitGetSubKSP(pc, &n, &blocks);
  std::pair<std::string, std::string> types{n > 0 ? pc_type(blocks[0]) : "",
                                            n > 1 ? pc_type(blocks[1]) : ""};
  PetscFree(blocks);
  return types;
}
} // namespace

TEST(SolverOptions, ALinearSolversDefaultsStayInItsOwnDatabase)
{
  Body first = make_body();
  NonlinearSolver stars(*first.problem, first.bcs, nullptr, with_solver("gmres-stars"));
  for (const char* name : {"-al_gamma", "-fieldsplit_u_pc_type", "-fieldsplit_q_ksp_type",
                           "-fieldsplit_u_mg_levels_pc_type"})
    EXPECT_FALSE(in_process_options(name))
        << name << ": gmres-stars' default was written into the process's options";
  EXPECT_EQ(pc_type(stars.linear_solver()), PCSHELL)
      << "gmres-stars is the Taylor-Hood shell (augmented Lagrangian, p-multigrid)";

  // a second solver with the plain Schur split: PCFIELDSPLIT with GAMG on u and MUMPS
  // on q, which it would not be under the first one's -al_gamma and mg
  Body second = make_body();
  NonlinearSolver schur(*second.problem, second.bcs, nullptr, with_solver("gmres-schur"));
  ASSERT_EQ(pc_type(schur.linear_solver()), PCFIELDSPLIT)
      << "gmres-schur after gmres-stars: the plain field split, not the stars' shell";
  const NewtonReport report = schur.solve();
  EXPECT_TRUE(report.converged) << report.reason;
  const auto [u, q] = split_blocks(schur.linear_solver());
  EXPECT_EQ(u, PCGAMG) << "the u block, set up inside the solve, read the first solver's mg";
  EXPECT_EQ(q, PCLU) << "the q block, set up inside the solve, read the first solver's q";

  // and the first still solves with its own options after the second was made
  const NewtonReport first_report = stars.solve();
  EXPECT_TRUE(first_report.converged) << first_report.reason;
  EXPECT_FALSE(in_process_options("-al_gamma")) << "after the gmres-stars solve";
}

TEST(SolverOptions, TheProcesssOptionsReachTheSolver)
{
  // a user's option, given before the solver is made, wins over the split's default
  PetscOptionsSetValue(nullptr, "-fieldsplit_u_pc_type", "jacobi");
  Body body = make_body();
  NonlinearSolver schur(*body.problem, body.bcs, nullptr, with_solver("gmres-schur"));
  PetscOptionsClearValue(nullptr, "-fieldsplit_u_pc_type");
  schur.solve(); // (Jacobi on u may not converge: the block's type is what is checked)
  EXPECT_EQ(split_blocks(schur.linear_solver()).first, PCJACOBI)
      << "-fieldsplit_u_pc_type jacobi from the process's options";
}
