// Fusiform muscle: isometric and free contraction (paper section "Fusiform
// muscle contraction").
//
//   fusiform --model {ble,wkm,giant,combi} --case {isometric,free}
//            --refinement {1,2,4} [--cell hex|tet] [--degree 1|2] [--no-fbar]
//            [--dt SECONDS] [--set NAME=VALUE ...] --out DIR    (all options: --help)
//
// Degree-1 hexahedra are F-bar elements unless --no-fbar (plain Q1 locks).
// A spindle 100 mm long along e3, radius 10 mm at the ends and 20 mm in the
// middle (meshes/fusiform.geo), fibres from a Laplace potential between origin
// and insertion, activated from t = 0 to 0.15 s.  Isometric: both ends clamped;
// the force through the mid-section is recorded.  Free: the origin clamped, the
// insertion held in-plane and moving as one along e3 (exact constraint, one
// extra unknown); the stretch ratio epsilon = 1 + u3/l is recorded.
//
// Writes DIR/series.csv, DIR/fields.xdmf, DIR/summary.json, DIR/series.png and
// DIR/surface.json (deformed surface for tools/render_surface.py).
#include <common/application.h>
#include <common/command_line.h>
#include <common/errors.h>
#include <fem/boundary.h>
#include <fem/condition_number.h>
#include <fem/element_choice.h>
#include <fem/fibres.h>
#include <fem/muscle_problem.h>
#include <fem/nonlinear_solver.h>
#include <fem/time_stepping.h>
#include <fem/uniform_constraint.h>
#include <io/gmsh_mesh.h>
#include <io/plotting.h>
#include <io/surface_export.h>
#include <material/time_functions.h>

#include <chrono>
#include <cstdio>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/io/XDMFFile.h>
#include <dolfinx/mesh/utils.h>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

using namespace muscle;
using namespace dolfinx;

namespace
{
constexpr double muscle_length = 100; // mm
constexpr double mid_section = 50;    // mm

struct Settings
{
  std::string model = "combi", load = "isometric", cell = "hex", out;
  std::string mesh = std::string(MUSCLE_SOURCE_DIR) + "/meshes/fusiform.geo";
  int refinement = 1, degree = 1, output_every = 1;
  Discretisation element;
  double dt = -1, t_end = 0.15, root_tolerance = default_root_tolerance;
  std::vector<std::string> assignments, mesh_numbers;
  bool quiet = false, no_fields = false, condition_number = false, anti_locking = false,
       fbar = false;
  NewtonOptions newton;
  int max_cutbacks = 8;
  double first_step = 0, growth_factor = 1.5;
};

Settings parse(std::vector<std::string> args)
{
  Settings s;
  CLI::App app{"Fusiform muscle contraction (isometric or free) for one model.\n"
               "PETSc options (-snes_monitor, -ksp_type ...) are passed through."};
  app.add_option("--model", s.model, "ble, wkm, giant or combi")->capture_default_str();
  app.add_option("--case", s.load, "isometric or free")->capture_default_str();
  app.add_option("--refinement", s.refinement, "mesh refinement n: 24n elements around, "
                 "20n along (1, 2 or 4)")->capture_default_str();
  app.add_option("--cell", s.cell, "hex or tet")->capture_default_str();
  app.add_option("--degree", s.degree, "displacement degree 1 or 2")->capture_default_str();
  app.add_option("--quadrature-degree", s.element.quadrature_degree,
                 "quadrature degree (default 2 for degree 1, 4 for degree 2; others need "
                 "MUSCLE_EXTRA_VARIANTS)");
  app.add_flag("--anti-locking", s.anti_locking,
               "BLE on Q1 hexahedra: stiff volumetric part on one point per cell "
               "(selective reduced integration)");
  bool fbar_on = false, fbar_off = false;
  CLI::Option* fbar_option = app.add_flag(
      "--fbar", fbar_on,
      "F-bar hexahedra (Q1), the paper's locking-free element: the default for --cell hex "
      "--degree 1");
  app.add_flag("--no-fbar", fbar_off,
               "plain Q1 hexahedra instead of F-bar (they lock: +6 % force at n = 1, "
               "BENCHMARKS.md)")
      ->excludes(fbar_option);
  bool displacement_newton = false;
  app.add_flag("--fbar-displacement-newton", displacement_newton,
               "F-bar: Newton on u alone (theta = J0(u)) instead of (u, theta, p); same "
               "solution, more iterations (BENCHMARKS.md)");
  app.add_option("--root-tolerance", s.root_tolerance,
                 "WKM/GIANT: relative step tolerance of the activation root finder "
                 "(default round-off; looser saves no time, BENCHMARKS.md)")
      ->capture_default_str();
  app.add_option("--dt", s.dt, "time step [s] (default 0.001 for WKM/GIANT, which resolves "
                 "the 4 ms twitch train, 0.005 for BLE/COMBI)");
  app.add_option("--t-end", s.t_end, "end time [s]")->capture_default_str();
  app.add_option("--set", s.assignments, "NAME=VALUE: override a material parameter")
      ->take_all();
  app.add_option("--out", s.out, "output directory")->required();
  app.add_option("--mesh", s.mesh, "Gmsh .geo/.msh with surfaces origin, insertion, "
                 "midsection (refinement and tet are passed as -setnumber)")
      ->capture_default_str();
  app.add_option("--mesh-set", s.mesh_numbers, "NAME=VALUE: a further Gmsh -setnumber "
                 "(fusiform.geo: core, the central block's radius fraction)")->take_all();
  app.add_option("--output-every", s.output_every, "write fields every N steps")
      ->capture_default_str();
  app.add_option("--linear-solver", s.newton.linear_solver,
                 "lu (MUMPS), gmres-hypre or gmres-gamg")
      ->check(CLI::IsMember(NewtonOptions::linear_solvers()))
      ->capture_default_str();
  app.add_option("--linear-rtol", s.newton.linear_rtol,
                 "relative tolerance of the iterative linear solvers")->capture_default_str();
  app.add_option("--line-search", s.newton.line_search,
                 "PETSc line search: cp (default, BENCHMARKS.md \"Line searches\"), bt, "
                 "basic or l2")
      ->check(CLI::IsMember(NewtonOptions::line_searches()))
      ->capture_default_str();
  app.add_option("--max-cutbacks", s.max_cutbacks, "halvings of a failing step")
      ->capture_default_str();
  app.add_option("--first-step", s.first_step,
                 "first sub-step [s] (default --dt); steps then grow by --growth-factor "
                 "after two successes, up to --dt");
  app.add_option("--growth-factor", s.growth_factor, "sub-step growth after two successes")
      ->capture_default_str();
  app.add_option("--stagnation-window", s.newton.stagnation_window,
                 "cut the step when the residual fell by less than 0.1 % over this many Newton "
                 "iterations (0: never)")->capture_default_str();
  app.add_flag("--no-fields", s.no_fields, "skip the XDMF fields");
  app.add_flag("--quiet", s.quiet, "no progress lines");
  app.add_flag("--condition-number", s.condition_number,
               "estimate the condition number of the last Newton matrix (SLEPc)");
  if (!parse_command_line(app, std::move(args)))
    std::exit(0);
  s.newton.fbar_cell_unknowns = !displacement_newton;
  if (s.load != "isometric" and s.load != "free")
    throw InputError("--case '" + s.load + "': allowed: isometric, free");
  if (s.refinement < 1 or s.refinement > 8)
    throw InputError("--refinement " + std::to_string(s.refinement) + ": allowed 1 to 8 "
                     "(the paper uses 1, 2, 4)");
  if (s.cell != "hex" and s.cell != "tet")
    throw InputError("--cell '" + s.cell + "': allowed: hex, tet");
  if (s.degree != 1 and s.degree != 2)
    throw InputError("--degree " + std::to_string(s.degree) + ": allowed 1 or 2");
  s.element.degree = s.degree;
  if (s.anti_locking)
  {
    if (s.cell != "hex" or s.degree != 1 or !parse_model(s.model).law().anti_locking)
      throw InputError("--anti-locking: only for --cell hex --degree 1 and a law whose file "
                       "gives volumetric_stiff_part (BLE; WKM, GIANT and COMBI are unstable "
                       "with a one-point penalty; Q2 does not lock; BENCHMARKS.md)");
    s.element.volumetric_quadrature_degree = 1;
  }
  try
  {
    s.fbar = use_fbar(fbar_on or fbar_off ? std::optional<bool>(fbar_on) : std::nullopt,
                      s.cell, s.degree, s.anti_locking);
  }
  catch (const InputError& e)
  {
    throw InputError(std::string("--fbar: ") + e.what());
  }
  s.element.fbar = s.fbar;
  if (!(s.root_tolerance >= 1e-16 and s.root_tolerance < 1))
    throw InputError("--root-tolerance " + std::to_string(s.root_tolerance)
                     + ": allowed from 1e-16 (round-off; smaller never stops) to below 1");
  if (s.dt == -1)
    s.dt = uses_twitch_train(parse_model(s.model)) ? 0.001 : 0.005;
  if (!(s.dt > 0) or !(s.t_end > 0))
    throw InputError("--dt and --t-end must be positive");
  if (!(s.first_step >= 0) or !(s.growth_factor >= 1))
    throw InputError("--first-step must be positive (0: --dt) and --growth-factor at least 1");
  return s;
}

double seconds_since(std::chrono::steady_clock::time_point start)
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
} // namespace

int main(int argc, char** argv)
{
  return run_application(argc, argv, [](std::vector<std::string> args) {
    const auto start = std::chrono::steady_clock::now();
    const Settings s = parse(std::move(args));
    ParameterSet parameters(parse_model(s.model));
    for (const std::string& a : s.assignments)
      parameters.set_assignment(a);
    parameters.validate();
    if (const std::string w = locking_warning(s.cell, s.degree, s.fbar, s.anti_locking, parameters);
        !w.empty() and dolfinx::MPI::rank(MPI_COMM_WORLD) == 0)
      std::fprintf(stderr, "warning: %s\n", w.c_str());
    std::filesystem::create_directories(s.out);

    // Mesh and tags from the Gmsh source
    std::map<std::string, double> numbers
        = {{"refinement", s.refinement}, {"tet", s.cell == "tet"}};
    for (const std::string& a : s.mesh_numbers)
    {
      const auto eq = a.find('=');
      try
      {
        if (eq == std::string::npos)
          throw std::invalid_argument(a);
        numbers[a.substr(0, eq)] = std::stod(a.substr(eq + 1));
      }
      catch (const std::exception&)
      {
        throw InputError("--mesh-set '" + a + "': expected NAME=NUMBER, e.g. core=0.9");
      }
    }
    const GmshMesh gm = read_gmsh(MPI_COMM_WORLD, s.mesh, numbers);
    auto mesh = gm.mesh;
    const int origin = gm.surface("origin"), insertion = gm.surface("insertion"),
              midsection = gm.surface("midsection");

    // The material and its fibres
    MuscleProblem problem(mesh, parameters, s.element);
    problem.set_root_tolerance(s.root_tolerance);
    const LaplaceFibres fibres = laplace_fibres(mesh, *gm.facet_tags, origin, insertion,
                                                problem.fibre()->function_space());
    problem.set_fibre(*fibres.fibre);

    // Boundary conditions
    auto V = problem.V();
    const auto origin_facets = tagged_facets(*gm.facet_tags, origin);
    const auto insertion_facets = tagged_facets(*gm.facet_tags, insertion);
    std::vector<std::shared_ptr<const fem::DirichletBC<double>>> bcs = {clamp(V, origin_facets)};
    std::shared_ptr<UniformDisplacementConstraint> constraint;
    if (s.load == "isometric")
      bcs.push_back(clamp(V, insertion_facets));
    else
    {
      auto zero = std::make_shared<fem::Constant<double>>(0.0);
      bcs.push_back(prescribe_component(V, insertion_facets, 0, zero));
      bcs.push_back(prescribe_component(V, insertion_facets, 1, zero));
      constraint = std::make_shared<UniformDisplacementConstraint>(
          *V, component_dofs(*V, insertion_facets, 2));
    }

    // Force through the mid-section: the residual of the lower half summed over
    // the mid-section nodes (variationally consistent section force)
    const std::int32_t num_cells = mesh->topology().index_map(3)->size_local()
                                   + mesh->topology().index_map(3)->num_ghosts();
    std::vector<std::int32_t> cells(num_cells), lower(num_cells);
    std::iota(cells.begin(), cells.end(), 0);
    const std::vector<double> midpoints = mesh::compute_midpoints(*mesh, 3, cells);
    for (std::int32_t c = 0; c < num_cells; ++c)
      lower[c] = midpoints[3 * c + 2] < mid_section ? 1 : 2;
    auto halves = std::make_shared<mesh::MeshTags<std::int32_t>>(mesh, 3, cells, lower);
    auto lower_residual = problem.residual_on_cells(halves, 1);
    const auto mid_dofs = component_dofs(*V, tagged_facets(*gm.facet_tags, midsection), 2);
    const auto origin_dofs = component_dofs(*V, origin_facets, 2);
    la::Vector<double> nodal(V->dofmap()->index_map, V->dofmap()->index_map_bs());
    auto section_force = [&]
    {
      std::fill(nodal.mutable_array().begin(), nodal.mutable_array().end(), 0.0);
      fem::assemble_vector<double>(nodal.mutable_array(), *lower_residual);
      nodal.scatter_rev(std::plus<double>());
      return sum_owned(nodal, mid_dofs);
    };

    // Solver and time stepping
    NonlinearSolver solver(problem, bcs, constraint, s.newton);
    const double volume0 = problem.volume();
    TimeSteppingOptions stepping;
    stepping.t_end = s.t_end;
    stepping.dt = s.dt;
    stepping.max_cutbacks = s.max_cutbacks;
    stepping.first_substep = s.first_step;
    stepping.growth_factor = s.growth_factor;
    QuasiStaticStepper stepper(problem, solver,
                               [&](double t) { problem.set_time_factor(time_factor(parameters, t)); },
                               stepping);

    // Outputs
    std::ofstream series;
    if (is_root())
    {
      series.open(s.out + "/series.csv");
      series << "t,activation,F33,F33_origin,epsilon,volume_change,newton_iterations,"
                "linear_iterations,cutbacks,wall_time\n";
      series.precision(12);
    }
    std::unique_ptr<io::XDMFFile> xdmf;
    if (!s.no_fields)
    {
      xdmf = std::make_unique<io::XDMFFile>(mesh->comm(), s.out + "/fields.xdmf", "w");
      xdmf->write_mesh(*mesh);
      xdmf->write_function(*problem.fibre(), 0.0);
    }
    auto write_fields = [&](double t)
    {
      if (!xdmf)
        return;
      xdmf->write_function(*problem.u(), t);
      const MuscleProblem::PostFields post = problem.post_fields();
      for (const auto& f : post.all())
        xdmf->write_function(*f, t);
    };
    if (!s.quiet and is_root())
      std::printf("fusiform %s %s, n=%d %s degree %d: %lld cells, %lld nodes, %lld unknowns\n",
                  s.model.c_str(), s.load.c_str(), s.refinement, s.cell.c_str(), s.degree,
                  static_cast<long long>(gm.num_cells), static_cast<long long>(gm.num_nodes),
                  static_cast<long long>(V->dofmap()->index_map->size_global() * 3
                                         + (constraint ? 1 - constraint->size() : 0)));

    int total_newton = 0, total_linear = 0, total_cutbacks = 0, step = 0;
    double F33 = 0, epsilon = 1, volume_change = 0;
    const int steps = static_cast<int>(std::ceil(s.t_end / s.dt - 1e-9));
    write_fields(0.0);
    auto failure = stepper.run(
        [&](const StepRecord& r)
        {
          ++step;
          total_newton += r.newton_iterations;
          total_linear += r.linear_iterations;
          total_cutbacks += r.cutbacks;
          F33 = section_force();
          solver.assemble_nodal_forces(nodal);
          const double F33_origin = -sum_owned(nodal, origin_dofs);
          epsilon = constraint ? 1 + constraint->value(*problem.u()->x()) / muscle_length : 1.0;
          const double dV = problem.volume() / volume0 - 1;
          volume_change = dV;
          const double elapsed = seconds_since(start);
          if (is_root())
            series << r.t << "," << problem.time_factor() << "," << F33 << "," << F33_origin
                   << "," << epsilon << "," << dV << "," << r.newton_iterations << ","
                   << r.linear_iterations << "," << r.cutbacks << "," << elapsed << std::endl;
          if (!s.quiet and is_root())
            std::printf("t=%.4f s  F33=%9.4f mN  epsilon=%.5f  dV=%+.2e  newton %2d%s  "
                        "%.1f s, ETA %.0f s\n",
                        r.t, F33, epsilon, dV, r.newton_iterations,
                        r.cutbacks ? (" (" + std::to_string(r.cutbacks) + " cutbacks)").c_str() : "",
                        elapsed, elapsed / step * (steps - step));
          if (step % s.output_every == 0 or step == steps)
            write_fields(r.t);
          return true;
        });

    // The last converged state is written whatever happened
    const MuscleProblem::PostFields post = problem.post_fields();
    export_deformed_surface(*problem.u(), *post.fibre_stretch, s.out + "/surface.json");
    ConditionEstimate condition;
    if (s.condition_number and step > 0)
      condition = estimate_condition_number(solver.system_matrix());
    if (is_root())
    {
      nlohmann::json summary = {
          {"model", s.model}, {"case", s.load}, {"refinement", s.refinement},
          {"cell", s.cell}, {"degree", s.degree},
          {"quadrature_degree", problem.quadrature_degree()}, {"anti_locking", s.anti_locking},
          {"fbar", s.fbar},
          {"root_tolerance", s.root_tolerance},
          {"dt", s.dt}, {"t_end", s.t_end},
          {"cells", gm.num_cells}, {"nodes", gm.num_nodes},
          {"unknowns", V->dofmap()->index_map->size_global() * 3},
          {"steps", step}, {"newton_iterations", total_newton},
          {"linear_iterations", total_linear}, {"cutbacks", total_cutbacks},
          {"F33", F33}, {"epsilon", epsilon}, {"volume_change", volume_change},
          {"wall_time", seconds_since(start)},
          {"ranks", dolfinx::MPI::size(MPI_COMM_WORLD)}, {"completed", !failure}};
      if (failure)
        summary["failure"] = failure->to_json();
      if (s.condition_number)
      {
        summary["condition_number"] = condition.condition;
        summary["eigenvalue_max"] = condition.lambda_max;
        summary["eigenvalue_min"] = condition.lambda_min;
      }
      std::ofstream(s.out + "/summary.json") << summary.dump(1) << "\n";
    }
    if (series.is_open())
      series.close();
    run_plot_script("demos/fusiform/plot_fusiform.py",
                    {s.out + "/series.png", s.model + " " + s.load + "=" + s.out + "/series.csv"});
    if (failure)
      throw SolveError(failure->message(failure->step, s.out));
    return 0;
  });
}
