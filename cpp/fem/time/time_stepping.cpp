#include "fem/time/time_stepping.h"
#include "fem/time/generalized_alpha.h"
#include "fem/newton/line_search_failure.h"
#include "fem/linear/linear_failure.h"

#include <cmath>
#include <dolfinx/mesh/utils.h>
#include <optional>
#include <sstream>

using namespace dolfinx;

namespace muscle
{

QuasiStaticStepper::QuasiStaticStepper(MuscleProblem& problem, NonlinearSolver& solver,
                                       std::function<void(double)> set_time,
                                       TimeSteppingOptions options)
    : _problem(problem), _solver(solver), _set_time(std::move(set_time)),
      _options(options)
{
}

namespace
{
std::string midpoint_text(const mesh::Mesh& mesh, std::int32_t cell)
{
  std::ostringstream s;
  s.precision(4);
  const std::vector<double> x = mesh::compute_midpoints(mesh, 3, std::span(&cell, 1));
  s << "(" << x[0] << ", " << x[1] << ", " << x[2] << ")";
  return s.str();
}
} // namespace

nlohmann::json StepFailure::to_json() const
{
  return {{"t_converged", t_converged}, {"t_attempted", t_attempted}, {"reason", reason},
          {"where", where}, {"newton_iterations", newton_iterations}, {"cutbacks", cutbacks},
          {"step_lengths", step_lengths}};
}

StepFailure QuasiStaticStepper::diagnose(double t_converged, double t_attempted, int step,
                                         const NewtonReport& report) const
{
  StepFailure f;
  f.t_converged = t_converged;
  f.t_attempted = t_attempted;
  f.step = step;
  f.reason = report.reason;
  f.step_lengths = report.step_lengths;
  if (report.non_finite)
    f.reason += ", non-finite residual";
  const auto mesh = _problem.mesh();
  // worst element at the failed iterate (collective)
  auto [J, cell] = _solver.min_jacobian_determinant();
  struct
  {
    double value;
    int rank;
  } local{std::isnan(J) ? -1e300 : J, 0}, global;
  MPI_Comm_rank(mesh->comm(), &local.rank);
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE_INT, MPI_MINLOC, mesh->comm());
  std::string where_local;
  if (global.rank == local.rank and cell >= 0)
    where_local = "smallest J = " + std::to_string(J) + " in the cell at "
                  + midpoint_text(*mesh, cell);
  // the text travels from the rank that has the worst cell
  int length = where_local.size();
  MPI_Bcast(&length, 1, MPI_INT, global.rank, mesh->comm());
  where_local.resize(length);
  MPI_Bcast(where_local.data(), length, MPI_CHAR, global.rank, mesh->comm());
  f.where = where_local;
  // kernel failures are counted per rank: the reduction is collective
  std::int64_t failures = report.kernel.failures, total = 0;
  MPI_Allreduce(&failures, &total, 1, MPI_INT64_T, MPI_SUM, mesh->comm());
  if (total > 0)
    f.where += "; activation kernel without admissible root at " + std::to_string(total)
               + " quadrature points";
  const std::string method = _solver.line_search();
  const std::string culprit = line_search_failure(report, method);
  if (f.reason.find("DIVERGED_LINEAR_SOLVE") != std::string::npos)
    // a smaller step rarely rescues an iterative solver that stalls (BENCHMARKS.md,
    // "Linear solvers, ranks and n = 4")
    f.advice = linear_failure_advice(report.linear_failure);
  else if (!culprit.empty()
           and (global.value > 0 or report.reason.find("DIVERGED_LINE_SEARCH") == 0))
    // inverted elements speak for a smaller step, unless no step was found at all
    f.advice = culprit + ": " + line_search_advice(method);
  else if (report.non_finite and global.value > 0
           and (report.residual_norms.empty() or !std::isfinite(report.residual_norms[0])))
    // not finite already at the last converged state with the new time's loads
    // (a trial point of the line search may overflow; that is not this): an
    // input, not the step
    f.advice = "the residual is not finite at the last converged state with the loads of the "
               "new time, so an input overflows: check the activation scale, the loads and the "
               "material parameters (a smaller time step cannot help)";
  else if (global.value <= 0)
    f.advice = "elements invert: use a smaller time step (--dt, scene time.step), a finer mesh, or "
               "quadratic elements";
  else
    f.advice = "a smaller time step (--dt, scene time.step), more cutbacks, or a lower "
               "incompressibility penalty (kappa)";
  return f;
}

std::string StepFailure::message(int step_number, const std::string& out) const
{
  return "Newton failed at step " + std::to_string(step_number) + " going from t = "
         + std::to_string(t_converged) + " to " + std::to_string(t_attempted) + " s (" + reason
         + "; " + std::to_string(cutbacks) + " cutbacks, " + std::to_string(newton_iterations)
         + " Newton iterations); " + where + ". The state at t = " + std::to_string(t_converged)
         + " s is written to " + out + ". Try: " + advice + ".";
}

std::optional<StepFailure>
QuasiStaticStepper::run(const std::function<bool(const StepRecord&)>& on_output)
{
  auto& u = *_problem.u()->x();
  std::vector<double> converged(u.array().begin(), u.array().end());
  const double dt = _options.dt;
  const double smallest = dt * std::pow(_options.cutback_factor, _options.max_cutbacks);
  const int steps = _options.steps();
  double t = _options.t_start;
  double h = _options.first_substep > 0 ? std::min(dt, _options.first_substep) : dt;
  int successes = _options.first_successes;
  for (int k = 1; k <= steps; ++k)
  {
    // each output time from the one before: a run resumed at a checkpoint's t
    // takes the very same steps as the uninterrupted run
    const double target = k == steps ? _options.t_end : std::min(t + dt, _options.t_end);
    StepRecord record;
    // a remainder below a twentieth of the sub-step joins it: a tiny step is
    // ruinous in dynamics (the mass term grows like 1/h^2, round-off with it)
    while (target - t > 1e-9 * dt)
    {
      const double next = target - (t + h) < 0.05 * h ? target : t + h;
      _set_time(next);
      if (_dynamics)
        _dynamics->begin_step(next - t);
      const NewtonReport report = _solver.solve();
      record.newton_iterations += report.iterations;
      record.linear_iterations += report.linear_iterations;
      if (report.converged)
      {
        t = next;
        if (_dynamics)
          _dynamics->accept_step();
        ++record.substeps;
        record.residual = report.residual_norms.empty() ? 0 : report.residual_norms.back();
        std::copy(u.array().begin(), u.array().end(), converged.begin());
        if (++successes >= 2)
          h = std::min(dt, h * _options.growth_factor);
        continue;
      }
      StepFailure failure = diagnose(t, next, k, report);
      if (_dynamics)
        _dynamics->reject_step();
      std::copy(converged.begin(), converged.end(), u.mutable_array().begin());
      u.scatter_fwd();
      _set_time(t);
      _solver.restore_displacement();
      successes = 0;
      ++record.cutbacks;
      h *= _options.cutback_factor;
      if (h < smallest * (1 - 1e-12))
      {
        failure.newton_iterations = record.newton_iterations;
        failure.cutbacks = record.cutbacks;
        return failure;
      }
    }
    t = target;
    record.t = t;
    record.next_substep = h;
    record.successes = successes;
    if (!on_output(record))
      break;
  }
  return std::nullopt;
}

} // namespace muscle
