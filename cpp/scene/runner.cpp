#include "runner.h"

#include "../common/errors.h"
#include "assembly_timing.h"
#include "clock.h"
#include "run_outputs.h"
#include "run_progress.h"
#include "scene_model.h"
#include "series_quantities.h"

#include <algorithm>
#include <dolfinx/la/Vector.h>
#include <filesystem>

namespace muscle
{

void run_scene(const Scene& scene, const RunOptions& options)
{
  const auto start = Clock::now();
  std::filesystem::create_directories(options.out);

  // The model: only what the scene needs
  SceneModel model = read_mesh(scene);
  choose_element(scene, model);
  add_parts(scene, model);
  add_boundary(scene, model);
  add_ties(scene, model);
  add_contacts(scene, model, options.quiet);
  add_loads(scene, model);
  add_dynamics(scene, model, options.quiet);
  SeriesQuantities series(scene, model);
  RunSummary summary;
  summary.built = describe_built(scene, model, options.quiet);
  summary.assembly = time_assemblies(scene, model, options.measure_assembly);
  summary.setup_s = seconds_since(start);

  // Where the stepping starts: the scene's start, or the checkpoint
  RunProgress progress{scene.time};
  if (options.resume)
    progress = resume(scene, model.state(), options);
  // The inputs at every output time before the first solve: a negative
  // activation at t = 0.1 s should not cost a run to 0.1 s
  const TimeSteppingOptions& stepping = progress.stepping;
  for (int k = 0; k <= progress.remaining_steps(); ++k)
    set_time(scene, model, std::min(stepping.t_start + k * stepping.dt, stepping.t_end));
  if (options.check_only)
    return;

  // The solver and the stepper; the stepper sets the inputs at every sub-step
  set_time(scene, model, stepping.t_start);
  NonlinearSolver solver(model.body, model.bcs, model.constraint, newton_options(scene, model));
  if (model.loads)
    solver.add_forms(model.loads->residuals(), model.loads->jacobians());
  for (const auto& c : model.contacts)
    solver.add_term(c);
  solver.restore_displacement();
  QuasiStaticStepper stepper(
      model.problem(), solver, [&](double t) { set_time(scene, model, t); }, stepping);
  if (model.dynamics)
  {
    // the initial acceleration from the forces at the start, or the checkpoint's
    if (options.resume)
      model.dynamics->restore();
    else
    {
      dolfinx::la::Vector<double> r0(model.problem().u()->x()->map(),
                                     model.problem().u()->x()->bs());
      solver.assemble_nodal_forces(r0);
      model.dynamics->start(r0, model.constraint.get());
    }
    solver.add_term(model.dynamics);
    stepper.set_dynamics(model.dynamics.get());
  }
  if (options.modes > 0)
    return write_natural_frequencies(model, solver, options);

  // Step to the end, with the outputs of every converged step; a formula gone
  // bad at a sub-step stops the run like a failed step
  RunOutputs outputs(scene, model, options, progress, series, solver, start);
  const auto stepping_start = Clock::now();
  try
  {
    summary.failure = stepper.run([&](const StepRecord& r) { return outputs.step(r); });
  }
  catch (const InputError& e)
  {
    summary.input_error = e.what();
  }
  summary.stepping_s = seconds_since(stepping_start);
  if (summary.failure)
    name_activation_scales(scene, model, *summary.failure);

  // The last converged state is kept whatever happened
  outputs.finish(summary);
  if (!summary.input_error.empty())
    throw InputError(summary.input_error + " (the state at the last converged step is written to "
                     + options.out + ")");
  if (summary.failure)
    throw SolveError(summary.failure->message(progress.step + 1, options.out));
}

} // namespace muscle
