#pragma once

#include "scene/clock.h"
#include "scene/field_output.h"
#include "scene/run_progress.h"
#include "scene/runner.h"
#include "scene/scene.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace muscle
{
struct SceneModel;
class SeriesQuantities;

/// What summary.json says about a run besides the counts of its steps.
struct RunSummary
{
  nlohmann::json built;    ///< describe_built
  nlohmann::json assembly; ///< time_assemblies (null: not measured)
  double setup_s = 0;      ///< mesh, fibres, forms, constraint
  double stepping_s = 0;   ///< the stepper's run, outputs included
  std::optional<StepFailure> failure;
  std::string input_error; ///< a formula gone bad at a sub-step
  nlohmann::json condition; ///< condition_number, eigenvalue_max, _min (null: not asked)
};

/// --modes: the lowest options.modes natural frequencies of the model at the
/// start (its tangent and mass), printed and written to options.out/modes.json.
void write_natural_frequencies(const SceneModel& model, NonlinearSolver& solver,
                               const RunOptions& options);

/// What a run writes into options.out: series.csv (a row per converged output
/// step), the fields (fields.xdmf, or fields_from_stepN.xdmf when resumed: a
/// killed run leaves its HDF5 file unclosed), a checkpoint, a progress line,
/// and at the end surface.json and summary.json.
class RunOutputs
{
public:
  /// Opens series.csv and the fields file and writes the starting state.
  /// `progress` is counted on by step(); `start`: when the run started.
  RunOutputs(const Scene& scene, const SceneModel& model, const RunOptions& options,
             RunProgress& progress, SeriesQuantities& series, const NonlinearSolver& solver,
             Clock::time_point start);

  /// After every converged output time: the series row, the progress line, the
  /// fields every fields_every steps and a checkpoint every checkpoint_every
  /// steps (both at the last step).  Returns true: go on.
  bool step(const StepRecord& r);

  /// surface.json and summary.json of the last converged state, also after a
  /// failure; closes series.csv.
  void finish(const RunSummary& summary);

private:
  void write_series_row(const StepRecord& r, double elapsed);
  void print_progress(const StepRecord& r, double elapsed) const;

  const Scene& _scene;
  const SceneModel& _model;
  const RunOptions& _options;
  RunProgress& _progress;
  SeriesQuantities& _series;
  const NonlinearSolver& _solver;
  const Clock::time_point _start;
  const int _first_step, _steps; ///< the step counts this run starts at and reaches
  const std::string _fields_path;
  std::ofstream _file; ///< series.csv, on rank 0
  FieldOutput _fields;
  std::vector<double> _last; ///< the series quantities at the last converged state
  double _output_time = 0;   ///< series, fields, checkpoints [s]
};

} // namespace muscle
