#pragma once

#include "scene/runner.h"
#include "scene/scene.h"

#include <dolfinx/fem/Function.h>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace muscle
{

/// Where a run stands: the stepper's settings and the counters summed over the
/// output steps so far.  A checkpoint keeps them, so that a resumed run takes
/// the very same steps and continues the same counts.
struct RunProgress
{
  TimeSteppingOptions stepping; ///< t_start, sub-step and successes where the stepper starts
  int step = 0;                 ///< converged output steps
  int newton_iterations = 0, linear_iterations = 0, cutbacks = 0;
  double previous_wall = 0; ///< wall time of the runs before a resume [s]

  /// The output steps left to t_end.
  int remaining_steps() const;
  /// Count a converged output step.
  void add(const StepRecord& r);
  /// The checkpoint's state after output step `r`; `elapsed`: wall time so far.
  nlohmann::json checkpoint_state(const Scene& scene, const StepRecord& r, double elapsed) const;
};

/// The names of the series columns, as series.csv and a checkpoint list them.
std::vector<std::string> series_columns(const Scene& scene);

/// --resume: the state `fields` (u, and the dynamic state) and the progress
/// from the checkpoint in options.out; series.csv cut back to the checkpoint's
/// step.  InputError if the scene's physics or series columns changed since
/// the checkpoint.
RunProgress resume(const Scene& scene,
                   const std::vector<std::shared_ptr<dolfinx::fem::Function<double>>>& fields,
                   const RunOptions& options);

} // namespace muscle
