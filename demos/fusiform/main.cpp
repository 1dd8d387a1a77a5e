// Fusiform muscle: isometric and free contraction (paper section "Fusiform
// muscle contraction"), one model and case per run.
//
//   fusiform --model {ble,wkm,giant,combi} --case {isometric,free}
//            --refinement {1,2,4} [--cell hex|tet] [--degree 1|2] [--no-fbar] [--taylor-hood]
//            [--dt SECONDS] [--set NAME=VALUE ...] --out DIR    (all options: --help)
//
// The scene runner with command-line options: the run is the scene file
// demos/scenes/fusiform_<case>.yaml with the options as its overrides
// (--refinement 2 is --set mesh.set.refinement=2, --dt 0.01 is --set
// time.step=0.01, ...), run by run_scene as muscle-run runs it.  A spindle
// 100 mm long along e3, fibres from a Laplace potential between origin and
// insertion, activated from t = 0 to 0.15 s.  Isometric: both ends clamped;
// free: the insertion moving as one along e3.  Writes DIR/series.csv (F33, the
// force through the mid-section; epsilon = 1 + u3/l, free), summary.json,
// fields.xdmf, surface.json, checkpoints and series.png.
#include <common/application.h>
#include <common/command_line.h>
#include <common/errors.h>
#include <fem/elements/element_choice.h>
#include <fem/linear/linear_solvers.h>
#include <io/plotting.h>
#include <scene/runner.h>
#include <scene/scene.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

using namespace muscle;

namespace
{
/// The fusiform scene with the command line's options as its overrides.
struct Run
{
  std::string model = default_model("muscle").name(), load = "isometric";
  std::vector<std::string> overrides; ///< KEY=VALUE, applied as muscle-run's --set
  RunOptions options;
};

/// "NAME=VALUE" of option `option` as the override "PREFIX.NAME=VALUE".
std::string assignment(const std::string& option, const std::string& prefix,
                       const std::string& text)
{
  if (text.find('=') == std::string::npos)
    throw InputError(option + " '" + text + "': expected NAME=VALUE");
  return prefix + "." + text;
}

Run parse(std::vector<std::string> args)
{
  Run run;
  CLI::App app{"Fusiform muscle contraction (isometric or free) for one model: the scene "
               "demos/scenes/fusiform_<case>.yaml with these options as overrides.\n"
               "PETSc options (-snes_monitor, -ksp_type ...) are passed through."};
  std::vector<std::string> models;
  for (const Model& m : all_models())
    models.push_back(m.name());
  app.add_option("--model", run.model, "the material law: " + join(models))
      ->check(CLI::IsMember(models))
      ->capture_default_str();
  app.add_option("--case", run.load, "isometric or free")
      ->check(CLI::IsMember({"isometric", "free"}))
      ->capture_default_str();
  int refinement = 1, degree = 1, quadrature_degree = 0, output_every = 1;
  std::string cell = "hex";
  app.add_option("--refinement", refinement, "mesh refinement n: 24n elements around, 20n "
                 "along (1 to 8; the paper uses 1, 2, 4)")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  app.add_option("--cell", cell, "hex or tet (six tetrahedra per hexahedron)")
      ->check(CLI::IsMember({"hex", "tet"}))
      ->capture_default_str();
  app.add_option("--degree", degree, "displacement degree 1 or 2")
      ->check(CLI::IsMember({1, 2}))
      ->capture_default_str();
  app.add_option("--quadrature-degree", quadrature_degree,
                 "quadrature degree (default 2 for degree 1, 4 for degree 2; others need "
                 "MUSCLE_EXTRA_VARIANTS)");
  bool anti_locking = false, fbar_on = false, fbar_off = false, displacement_newton = false;
  app.add_flag("--anti-locking", anti_locking,
               "BLE on Q1 hexahedra: stiff volumetric part on one point per cell "
               "(selective reduced integration)");
  CLI::Option* fbar_option = app.add_flag(
      "--fbar", fbar_on,
      "F-bar hexahedra (Q1), the paper's locking-free element: the default for --cell hex "
      "--degree 1");
  app.add_flag("--no-fbar", fbar_off,
               "plain Q1 hexahedra instead of F-bar (they lock: +6 % force at n = 1, "
               "BENCHMARKS.md)")
      ->excludes(fbar_option);
  bool taylor_hood = false;
  app.add_flag("--taylor-hood", taylor_hood,
               "Taylor-Hood elements (with --degree 2: Q2-Q1, P2-P1), the pressure an unknown "
               "of its own")
      ->excludes(fbar_option);
  app.add_flag("--fbar-displacement-newton", displacement_newton,
               "F-bar: Newton on u alone (theta = J0(u)) instead of (u, theta, p); same "
               "solution, more iterations (BENCHMARKS.md)");
  std::string root_tolerance, linear_rtol, linear_solver, line_search, max_cutbacks,
      growth_factor, stagnation_window;
  app.add_option("--root-tolerance", root_tolerance,
                 "WKM/GIANT: relative step tolerance of the activation root finder "
                 "(default 1e-15, round-off; looser saves no time, BENCHMARKS.md)")
      ->type_name("TOL");
  // as given: the scene reads them as it reads its own numbers
  std::string dt, t_end;
  const CLI::Validator positive(
      [](std::string& v) -> std::string
      {
        std::size_t end = 0;
        try
        {
          if (const double x = std::stod(v, &end); end == v.size() and x > 0 and std::isfinite(x))
            return "";
        }
        catch (const std::exception&)
        {
        }
        return "'" + v + "' is not a positive number";
      },
      "");
  app.add_option("--dt", dt, "time step [s] (default 0.001 for WKM/GIANT, which resolves "
                 "the 4 ms twitch train, 0.005 for BLE/COMBI)")
      ->check(positive)
      ->type_name("S");
  app.add_option("--t-end", t_end, "end time [s] (default 0.15)")
      ->check(positive)
      ->type_name("S");
  std::vector<std::string> sets, mesh_numbers;
  app.add_option("--set", sets, "NAME=VALUE: a material parameter (kappa=100), or any scene "
                 "key as a dotted path (time.max_cutbacks=4)")
      ->take_all();
  app.add_option("--mesh-set", mesh_numbers, "NAME=VALUE: a further Gmsh -setnumber "
                 "(fusiform.geo: core, the central block's radius fraction)")->take_all();
  app.add_option("--output-every", output_every, "write fields every N steps")
      ->capture_default_str();
  std::string solvers;
  for (const LinearSolverType& type : linear_solver_table())
    solvers += (solvers.empty() ? "" : ", ") + type.name + " (" + type.summary + ")";
  app.add_option("--linear-solver", linear_solver, solvers)
      ->check(CLI::IsMember(NewtonOptions::linear_solvers()));
  app.add_option("--linear-rtol", linear_rtol,
                 "relative tolerance of the iterative linear solvers (default 1e-10)")
      ->type_name("R");
  app.add_option("--line-search", line_search,
                 "PETSc line search: cp (the fusiform scenes' default: the fewest Newton "
                 "iterations there, BENCHMARKS.md \"Line searches\"), basic (full Newton "
                 "steps), bt or l2")
      ->check(CLI::IsMember(NewtonOptions::line_searches()));
  app.add_option("--max-cutbacks", max_cutbacks, "halvings of a failing step (default 8)")
      ->type_name("N");
  app.add_option("--growth-factor", growth_factor,
                 "sub-step growth after two successes (default 1.5)")
      ->type_name("G");
  app.add_option("--stagnation-window", stagnation_window,
                 "cut the step when the residual fell by less than 0.1 % over this many Newton "
                 "iterations (0: never; default 5)")
      ->type_name("N");
  bool no_fields = false;
  app.add_flag("--no-fields", no_fields, "skip the XDMF fields");
  add_run_options(app, run.options)->required();
  if (!parse_command_line(app, std::move(args)))
    std::exit(0);

  // the options as scene keys, in the order given here
  auto set = [&](const std::string& key, const std::string& value)
  { run.overrides.push_back(key + "=" + value); };
  auto set_given = [&](const std::string& option, const std::string& key,
                       const std::string& value)
  {
    if (app.count(option))
      set(key, value);
  };
  if (app.count("--model"))
  {
    std::string name = run.model;
    std::transform(name.begin(), name.end(), name.begin(), ::toupper);
    set("title", name + " fusiform muscle, " + run.load);
    set("parts[0].material.model", run.model);
  }
  set_given("--refinement", "mesh.set.refinement", std::to_string(refinement));
  if (cell == "tet")
    set("mesh.set.tet", "1");
  for (const std::string& a : mesh_numbers)
    run.overrides.push_back(assignment("--mesh-set", "mesh.set", a));
  set_given("--degree", "element.degree", std::to_string(degree));
  set_given("--quadrature-degree", "element.quadrature_degree",
            std::to_string(quadrature_degree));
  if (anti_locking)
  {
    if (cell != "hex" or degree != 1 or !parse_model(run.model).law().anti_locking)
      throw InputError("--anti-locking: only for --cell hex --degree 1 and a law whose file "
                       "gives volumetric_stiff_part (BLE; WKM, GIANT and COMBI are unstable "
                       "with a one-point penalty; Q2 does not lock; BENCHMARKS.md)");
    set("element.volumetric_quadrature_degree", "1");
  }
  if (fbar_on or fbar_off)
  {
    try
    {
      use_fbar(fbar_on, cell, degree, anti_locking);
    }
    catch (const InputError& e)
    {
      throw InputError(std::string("--fbar: ") + e.what());
    }
    set("element.fbar", fbar_on ? "true" : "false");
  }
  if (taylor_hood)
    set("element.taylor_hood", "true");
  // the scene's step is BLE's and COMBI's; WKM and GIANT resolve the twitch train
  if (!app.count("--dt"))
    dt = uses_twitch_train(parse_model(run.model)) ? "0.001" : "0.005";
  if (app.count("--t-end"))
  {
    set("time.end", t_end);
    if (std::stod(t_end) < std::stod(dt))
      dt = t_end;
  }
  set("time.step", dt);
  set_given("--max-cutbacks", "time.max_cutbacks", max_cutbacks);
  set_given("--growth-factor", "time.growth_factor", growth_factor);
  set_given("--linear-solver", "solver.linear", linear_solver);
  set_given("--linear-rtol", "solver.linear_rtol", linear_rtol);
  set_given("--line-search", "solver.line_search", line_search);
  set_given("--stagnation-window", "solver.stagnation_window", stagnation_window);
  set_given("--root-tolerance", "solver.root_tolerance", root_tolerance);
  if (displacement_newton)
    set("solver.fbar_cell_unknowns", "false");
  if (no_fields)
    set("output.fields", "false");
  set_given("--output-every", "output.fields_every", std::to_string(output_every));
  for (const std::string& a : sets)
    run.overrides.push_back(a.find_first_of(".[") < a.find('=')
                                ? a
                                : assignment("--set", "parts[0].material.parameters", a));
  return run;
}
} // namespace

int main(int argc, char** argv)
{
  return run_application(argc, argv, [](std::vector<std::string> args) {
    const Run run = parse(std::move(args));
    const Scene scene = read_scene(std::string(MUSCLE_SOURCE_DIR) + "/demos/scenes/fusiform_"
                                       + run.load + ".yaml",
                                   run.overrides);
    // series.png from what was converged, also when the run stopped early
    const auto plot = [&]
    {
      const std::string series = run.options.out + "/series.csv";
      if (!run.options.check_only and scene.output.plots and std::filesystem::exists(series))
        run_plot_script("demos/fusiform/plot_fusiform.py",
                        {run.options.out + "/series.png",
                         run.model + " " + run.load + "=" + series});
    };
    try
    {
      run_scene(scene, run.options);
    }
    catch (const SolveError&)
    {
      plot();
      throw;
    }
    plot();
    return 0;
  });
}
