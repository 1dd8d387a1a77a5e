#pragma once

#include "fem/newton/newton_options.h"

#include <string>

namespace muscle
{

/// Why a failed Newton solve points at its line search (`method`), in words a
/// stop message can carry, or "" when it does not: the line search found no
/// acceptable step (DIVERGED_LINE_SEARCH), it crept (the solver's creep guard:
/// tiny accepted steps in a row), or it cut most Newton steps to less
/// than a tenth (median lambda) while the residual stalled.  The latter is how
/// bending of a nearly incompressible body fails: the straight line of a
/// linearised rotation changes the volume at second order, so along the
/// Newton direction the residual norm and the energy rise steeply, while full
/// steps converge (demos/scenes/cantilever_pressure.yaml, BENCHMARKS.md "Line
/// searches").  A smaller time step hardly helps there: the rise shrinks only
/// in proportion to the load step.
std::string line_search_failure(const NewtonReport& report, const std::string& method);

/// The advice for such a failure: the other line searches and where to set
/// them.
std::string line_search_advice(const std::string& method);

} // namespace muscle
