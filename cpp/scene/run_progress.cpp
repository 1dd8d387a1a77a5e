#include "scene/run_progress.h"

#include "common/application.h"
#include "common/errors.h"
#include "scene/checkpoint.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>

namespace muscle
{
namespace
{
std::size_t fingerprint(const std::string& text) { return std::hash<std::string>{}(text); }
} // namespace

int RunProgress::remaining_steps() const
{
  return stepping.steps();
}

void RunProgress::add(const StepRecord& r)
{
  ++step;
  newton_iterations += r.newton_iterations;
  linear_iterations += r.linear_iterations;
  cutbacks += r.cutbacks;
}

nlohmann::json RunProgress::checkpoint_state(const Scene& scene, const StepRecord& r,
                                             double elapsed) const
{
  return {{"step", step}, {"t", r.t}, {"next_substep", r.next_substep},
          {"successes", r.successes}, {"newton_iterations", newton_iterations},
          {"linear_iterations", linear_iterations}, {"cutbacks", cutbacks},
          {"wall_time", elapsed},
          {"scene_fingerprint", fingerprint(scene.physics)},
          {"series_columns", series_columns(scene)}};
}

std::vector<std::string> series_columns(const Scene& scene)
{
  std::vector<std::string> columns;
  for (const SeriesQuantity& q : scene.output.series)
    columns.push_back(q.name);
  return columns;
}

RunProgress resume(const Scene& scene,
                   const std::vector<std::shared_ptr<dolfinx::fem::Function<double>>>& fields,
                   const RunOptions& options)
{
  const nlohmann::json state = read_checkpoint(fields, options.out);
  if (state.value("scene_fingerprint", std::size_t(0)) != fingerprint(scene.physics))
    throw InputError("--resume: the scene's mesh, element, parts (materials, data files) or "
                     "boundary changed since the checkpoint in " + options.out + " was "
                     "written (time, solver and output settings may change); run without "
                     "--resume to start afresh");
  const std::vector<std::string> columns = series_columns(scene);
  if (state.value("series_columns", std::vector<std::string>{}) != columns)
    throw InputError("--resume: output.series changed since the checkpoint in " + options.out
                     + " (columns now: " + join(columns) + "); keep the series columns to "
                     "continue the same series.csv");
  RunProgress progress{scene.time};
  progress.step = state.at("step");
  progress.stepping.t_start = state.at("t");
  progress.stepping.first_substep = state.at("next_substep");
  progress.stepping.first_successes = state.at("successes");
  progress.newton_iterations = state.at("newton_iterations");
  progress.linear_iterations = state.at("linear_iterations");
  progress.cutbacks = state.at("cutbacks");
  progress.previous_wall = state.at("wall_time");
  if (is_root())
  {
    // keep the series up to the checkpoint
    const std::string series_path = options.out + "/series.csv";
    std::ifstream in(series_path);
    std::vector<std::string> lines;
    for (std::string line;
         std::getline(in, line) and lines.size() < std::size_t(progress.step) + 1;)
      lines.push_back(line);
    std::ofstream out(series_path);
    for (const auto& line : lines)
      out << line << "\n";
  }
  if (!options.quiet and is_root())
    std::printf("resuming at t = %.6g s (step %d)\n", progress.stepping.t_start, progress.step);
  return progress;
}

} // namespace muscle
