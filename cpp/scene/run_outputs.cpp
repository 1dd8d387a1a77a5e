#include "scene/run_outputs.h"

#include "common/application.h"
#include "common/errors.h"
#include "fem/analysis/eigenfrequencies.h"
#include "fem/time/generalized_alpha.h"
#include "scene/checkpoint.h"
#include "scene/scene_model.h"
#include "scene/series_quantities.h"

#include <cmath>
#include <cstdio>
#include <dolfinx/common/MPI.h>

namespace muscle
{

void write_natural_frequencies(const SceneModel& model, NonlinearSolver& solver,
                               const RunOptions& options)
{
  if (!model.dynamics)
    throw InputError("--modes needs the mass: a dynamic scene ('dynamics: {method: "
                     "generalized_alpha}' and every part's density)");
  const std::vector<double> omega = natural_frequencies(
      solver.assemble_tangent(), model.dynamics->mass(), model.constraint.get(), options.modes);
  nlohmann::json modes = nlohmann::json::array();
  for (std::size_t i = 0; i < omega.size(); ++i)
  {
    const double f = omega[i] / (2 * M_PI);
    modes.push_back({{"mode", i + 1}, {"frequency_hz", f}, {"angular_frequency", omega[i]},
                     {"period_s", 1 / f}});
    if (!options.quiet and is_root())
      std::printf("mode %zu: %.6g Hz (period %.6g s)\n", i + 1, f, 1 / f);
  }
  if (is_root())
    std::ofstream(options.out + "/modes.json") << nlohmann::json{{"modes", modes}}.dump(1)
                                                 << "\n";
  if (omega.size() < std::size_t(options.modes))
    throw SolveError("--modes " + std::to_string(options.modes) + ": SLEPc converged only "
                     + std::to_string(omega.size()) + " eigenvalues");
}

RunOutputs::RunOutputs(const Scene& scene, const SceneModel& model, const RunOptions& options,
                       RunProgress& progress, SeriesQuantities& series,
                       const NonlinearSolver& solver, Clock::time_point start)
    : _scene(scene), _model(model), _options(options), _progress(progress), _series(series),
      _solver(solver), _start(start), _first_step(progress.step),
      _steps(progress.step + progress.remaining_steps()),
      _fields_path(options.out
                   + (options.resume ? "/fields_from_step" + std::to_string(progress.step) + ".xdmf"
                                     : "/fields.xdmf")),
      _fields(model, scene.output.fields ? _fields_path : "", progress.stepping.t_start)
{
  if (is_root())
  {
    _file.open(options.out + "/series.csv", options.resume ? std::ios::app : std::ios::trunc);
    _file.precision(12);
    if (!options.resume)
    {
      _file << "t";
      for (const std::string& name : series_columns(scene))
        _file << "," << name;
      _file << ",newton_iterations,linear_iterations,cutbacks,residual,wall_time\n";
    }
  }
  _fields.write(options.resume ? progress.stepping.t_start : 0.0);
  // the quantities at the start (a resumed run with nothing left to do reports these)
  _last = _series.measure(_solver);
}

bool RunOutputs::step(const StepRecord& r)
{
  _progress.add(r);
  const auto output_start = Clock::now();
  _last = _series.measure(_solver);
  const double elapsed = _progress.previous_wall + seconds_since(_start);
  if (is_root())
    write_series_row(r, elapsed);
  if (!_options.quiet and is_root())
    print_progress(r, elapsed);
  const int step = _progress.step;
  if (step % _scene.output.fields_every == 0 or step == _steps)
    _fields.write(r.t);
  if (step % _scene.output.checkpoint_every == 0 or step == _steps)
    write_checkpoint(_model.state(), _options.out,
                     _progress.checkpoint_state(_scene, r, elapsed));
  _output_time += seconds_since(output_start);
  return true;
}

void RunOutputs::write_series_row(const StepRecord& r, double elapsed)
{
  _file << r.t;
  for (double v : _last)
    _file << "," << v;
  _file << "," << r.newton_iterations << "," << r.linear_iterations << "," << r.cutbacks << ","
        << r.residual << "," << elapsed << std::endl;
}

void RunOutputs::print_progress(const StepRecord& r, double elapsed) const
{
  std::string values;
  for (std::size_t k = 0; k < _last.size() and k < 3; ++k)
  {
    char text[64];
    std::snprintf(text, sizeof text, "  %s=%.6g", _scene.output.series[k].name.c_str(),
                  _last[k]);
    values += text;
  }
  const int step = _progress.step;
  const double run_time = seconds_since(_start);
  std::printf("t=%.4f s  step %d/%d  newton %2d  |R|=%.1e%s%s  %.1f s, ETA %.0f s\n", r.t, step,
              _steps, r.newton_iterations, r.residual, values.c_str(),
              r.cutbacks ? ("  (" + std::to_string(r.cutbacks) + " cutbacks)").c_str() : "",
              elapsed, run_time / (step - _first_step) * (_steps - step));
  std::fflush(stdout);
}

void RunOutputs::finish(const RunSummary& s)
{
  if (_scene.output.surface)
    _fields.write_surface(_options.out + "/surface.json");
  if (is_root())
  {
    const Scene& scene = _scene;
    const RunProgress& p = _progress;
    nlohmann::json summary = {
        {"scene", scene.file}, {"title", scene.title},
        {"model", to_string(scene.parts[0].parameters.model())},
        {"cells", _model.gm.num_cells}, {"nodes", _model.gm.num_nodes},
        {"degree", scene.mesh.degree},
        {"dt", scene.time.dt}, {"t_end", scene.time.t_end}, {"steps", p.step},
        {"newton_iterations", p.newton_iterations}, {"linear_iterations", p.linear_iterations},
        {"cutbacks", p.cutbacks}, {"wall_time", p.previous_wall + seconds_since(_start)},
        {"resumed", _options.resume}, {"ranks", dolfinx::MPI::size(MPI_COMM_WORLD)},
        {"completed", !s.failure and s.input_error.empty()}, {"built", s.built},
        {"timings", {{"setup_s", s.setup_s},
                     {"solve_s", s.stepping_s - _output_time},
                     {"output_s", _output_time}}},
        {"fields", scene.output.fields ? _fields_path : ""},
        {"overrides", scene.overrides}, {"warnings", _model.warnings}};
    for (std::size_t k = 0; k < _last.size(); ++k)
      summary["final"][scene.output.series[k].name] = _last[k];
    if (!s.assembly.is_null())
      summary["assembly"] = s.assembly;
    if (!s.condition.is_null())
      summary.update(s.condition);
    if (!s.input_error.empty())
      summary["failure"] = {{"reason", s.input_error}};
    if (s.failure)
      summary["failure"] = s.failure->to_json();
    std::ofstream(_options.out + "/summary.json") << summary.dump(1) << "\n";
  }
  if (_file.is_open())
    _file.close();
}

} // namespace muscle
