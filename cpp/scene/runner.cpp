#include "scene/runner.h"

#include "common/command_line.h"
#include "common/errors.h"
#include "common/petsc_options.h"
#include "fem/analysis/condition_number.h"
#include "scene/assembly_timing.h"
#include "scene/clock.h"
#include "scene/run_outputs.h"
#include "scene/run_progress.h"
#include "scene/scene_model.h"
#include "scene/series_quantities.h"

#include <algorithm>
#include <cctype>
#include <dolfinx/la/Vector.h>
#include <filesystem>
#include <petscsys.h>

namespace muscle
{

namespace
{
/// An option's name starts with '-'; a negative number ("-1", "-.5") is a value
/// (PETSc's own rule for its command line)
bool is_option_name(const std::string& word)
{
  return word.size() > 1 and word[0] == '-'
         and !(std::isdigit(static_cast<unsigned char>(word[1])) or word[1] == '.');
}

/// The scene's PETSc options (solver.petsc), each unless the command line gave it.
void set_petsc_options(const std::vector<std::string>& words)
{
  for (std::size_t i = 0; i < words.size(); ++i)
  {
    if (!is_option_name(words[i]))
      continue;
    const bool has_value = i + 1 < words.size() and !is_option_name(words[i + 1]);
    set_unless_given(words[i].c_str(), has_value ? words[i + 1].c_str() : nullptr);
  }
}

/// The inertia term joins the solver and the stepper, with the acceleration of
/// the forces at the start (M a_0 = -r_0) or the checkpoint's state.
void start_dynamics(SceneModel& model, NonlinearSolver& solver, QuasiStaticStepper& stepper,
                    bool resume)
{
  if (resume)
    model.dynamics->restore();
  else
  {
    const auto& u = *model.problem().u()->x();
    dolfinx::la::Vector<double> r0(u.map(), u.bs());
    solver.assemble_nodal_forces(r0);
    model.dynamics->start(r0, model.constraint.get());
  }
  solver.add_term(model.dynamics);
  stepper.set_dynamics(model.dynamics.get());
}

/// The condition number of the last Newton matrix, for summary.json.
nlohmann::json condition_number(NonlinearSolver& solver)
{
  const ConditionEstimate c = estimate_condition_number(solver.system_matrix());
  return {{"condition_number", c.condition},
          {"eigenvalue_max", c.lambda_max},
          {"eigenvalue_min", c.lambda_min}};
}
} // namespace

void run_scene(const Scene& scene, const RunOptions& options)
{
  const auto start = Clock::now();
  // before the mesh: the answer would come only after the whole run
  if (options.condition_number and scene.mesh.taylor_hood)
    throw InputError("--condition-number: the Taylor-Hood Newton matrix holds the pressure "
                     "(an indefinite saddle point); the estimate needs a displacement element "
                     "(element.taylor_hood: false)");
  std::filesystem::create_directories(options.out);
  set_petsc_options(scene.petsc_options);

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
    start_dynamics(model, solver, stepper, options.resume);
  if (options.modes > 0)
    return write_natural_frequencies(model, solver, options);

  // Step to the end, with the outputs of every converged step; a formula gone
  // bad at a sub-step stops the run like a failed step
  RunOutputs outputs(scene, model, options, progress, series, solver, start);
  const int first_step = progress.step;
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
  if (options.condition_number and progress.step > first_step)
    summary.condition = condition_number(solver);

  // The last converged state is kept whatever happened
  outputs.finish(summary);
  if (!summary.input_error.empty())
    throw InputError(summary.input_error + " (the state at the last converged step is written to "
                     + options.out + ")");
  if (summary.failure)
    throw SolveError(summary.failure->message(progress.step + 1, options.out));
}

CLI::Option* add_run_options(CLI::App& app, RunOptions& options)
{
  CLI::Option* out = app.add_option("--out", options.out, "output directory");
  app.add_flag("--resume", options.resume,
               "continue a stopped run from the checkpoint in the output directory");
  app.add_flag("--quiet", options.quiet, "no progress lines");
  app.add_flag("--check", options.check_only,
               "read the scene and build the mesh, surfaces and forms; solve nothing");
  app.add_option("--measure-assembly", options.measure_assembly,
                 "time N residual/Jacobian assemblies of the scene's forms and of the plain "
                 "passive forms before the run");
  app.add_flag("--condition-number", options.condition_number,
               "after the run: the condition number of the last Newton matrix (SLEPc) into "
               "summary.json; not with Taylor-Hood elements");
  return out;
}

} // namespace muscle
