#pragma once

#include "fem/elements/muscle_problem.h"
#include "fem/newton/nonlinear_solver.h"
#include "loadcases/load_case.h"

#include <functional>
#include <memory>
#include <vector>

namespace muscle
{

struct CubeOptions
{
  Discretisation discretisation;
  int cells_per_side = 1;  ///< the paper: one hexahedron
  double max_increment = 0.05; ///< largest step of the control value
  int max_cutbacks = 12;
  /// bt, not the default cp: bt takes the full Newton step near the solution,
  /// so Newton converges quadratically on the homogeneous cube (tested); with
  /// cp's secant step lengths BLE's cube converges with order 0.8
  NewtonOptions newton = []
  {
    NewtonOptions o;
    o.line_search = "bt";
    return o;
  }();
};

/// One point of the FE response.
struct CubeResult
{
  double control = 0;   ///< stretch (shear for SAF)
  double stress = 0;    ///< reaction on the loaded face / reference area [kPa]
  double volume_ratio = 1;
  int newton_iterations = 0; ///< summed over the increments to reach it
  bool converged = false;
  std::string message; ///< why it failed, if it did
};

/// The unit cube under the Dirichlet conditions of the paper's Table
/// constraints_cube, driven to a sequence of control values: the nearly
/// incompressible FE counterpart of the exact homogeneous response.
///
/// Rollers on the faces X_i = 0 remove rigid motions without constraining the
/// lateral contraction; the loaded face moves by d (lambda - 1) (or the shear
/// d nu for SAF); pure-shear cases hold the third direction on both faces.  The
/// reported stress is the sum of the nodal forces on the loaded face, i.e. the
/// nominal stress the testing machine measures.
class CubeLoadCase
{
public:
  CubeLoadCase(const ParameterSet& parameters, MuscleState state, LoadCase load_case,
               CubeOptions options = {});
  ~CubeLoadCase();

  /// Responses at the given controls, reached by continuation from the
  /// undeformed state outwards (cut back on Newton failure).
  std::vector<CubeResult> solve(const std::vector<double>& controls);

  /// Drive to one control value from the current state.
  CubeResult advance_to(double control);

  /// Newton residual history of the last increment (for convergence studies).
  const NewtonReport& last_report() const { return _last; }

  MuscleProblem& problem() { return *_problem; }

private:
  /// Drive `set(value)` from `current` to `target` in increments of at most
  /// `max_step`, halving on Newton failure.  (No extrapolated predictor: its
  /// second-order volume error costs the exponential volumetric penalty more
  /// Newton steps than the lifted first Newton step, which is the tangent
  /// predictor.)
  bool continuation(const std::function<void(double)>& set, double& current,
                    double target, double max_step, CubeResult& result);
  void apply_control(double s);
  double reaction() const;
  void reset();

  LoadCase _case;
  CubeOptions _options;
  std::shared_ptr<MuscleProblem> _problem;
  std::unique_ptr<NonlinearSolver> _solver;
  std::vector<std::shared_ptr<dolfinx::fem::Constant<double>>> _loads;
  std::vector<std::int32_t> _loaded_dofs; ///< local unrolled dofs of the loaded face
  double _current;
  double _time_factor = 0;
  double _target_time_factor;
  NewtonReport _last;
};

} // namespace muscle
