// muscle-run: run a muscle scene described in a YAML file.
//
//   muscle-run SCENE.yaml [--out DIR] [--resume] [--quiet] [--check]
//              [--set KEY=VALUE ...] [--t-end T] [--measure-assembly N]
//              [--condition-number] [PETSc options]
//
// Reads and checks the whole scene before building anything, builds only what
// the scene needs, and writes DIR/series.csv, fields.xdmf, summary.json,
// series.png, surface.json and a checkpoint after every converged step.
// Example scenes: demos/scenes/*.yaml.
#include <common/application.h>
#include <common/command_line.h>
#include <common/errors.h>
#include <io/plotting.h>
#include <scene/runner.h>
#include <scene/scene.h>

#include <cstdio>
#include <filesystem>

using namespace muscle;

int main(int argc, char** argv)
{
  return run_application(argc, argv, [](std::vector<std::string> args) {
    std::string path;
    RunOptions options;
    CLI::App app{"Run a muscle scene (YAML).  PETSc options (-snes_monitor, -ksp_type ...) "
                 "are passed through; the scene's solver.petsc options come first."};
    app.add_option("scene", path, "scene file, e.g. demos/scenes/fusiform_isometric.yaml")
        ->required();
    add_run_options(app, options)->description("output directory (default: out/<scene name>)");
    std::vector<std::string> overrides;
    app.add_option("--set", overrides,
                   "replace a scene value, KEY a dotted path with list indices, e.g. "
                   "--set parts[0].material.parameters.kappa=100 --set time.step=0.01 "
                   "(checked as in the file; repeat for several)")
        ->expected(1)
        ->take_all();
    double t_end = -1;
    app.add_option("--t-end", t_end, "stop at this time instead of the scene's time.end "
                   "(a short look at a long scene)");
    app.add_option("--modes", options.modes,
                   "write the N lowest natural frequencies at the start (SLEPc; a dynamic "
                   "scene) to OUT/modes.json and stop")
        ->check(CLI::Range(1, 1000));
    if (!parse_command_line(app, std::move(args)))
      return 0;
    Scene scene = read_scene(path, overrides);
    if (t_end != -1)
    {
      if (!(t_end > 0))
        throw InputError("--t-end " + std::to_string(t_end) + ": must be > 0");
      scene.time.t_end = t_end;
      scene.time.dt = std::min(scene.time.dt, t_end);
    }
    if (options.out.empty())
      options.out = "out/" + std::filesystem::path(path).stem().string();
    // series.png from what was converged, also when the run stopped early
    const auto plot = [&]
    {
      const std::string series = options.out + "/series.csv";
      if (!options.check_only and scene.output.plots and !scene.output.series.empty()
          and std::filesystem::exists(series))
        run_plot_script("demos/scene/plot_series.py",
                        {options.out + "/series.png", series, scene.title});
    };
    try
    {
      run_scene(scene, options);
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
