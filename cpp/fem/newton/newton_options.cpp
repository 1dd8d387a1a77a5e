#include "fem/newton/newton_options.h"

#include "fem/linear/linear_solvers.h"

#include "common/errors.h"

#include <algorithm>

namespace muscle
{

const std::vector<std::string>& NewtonOptions::linear_solvers()
{
  return linear_solver_names();
}

const std::vector<std::string>& NewtonOptions::line_searches()
{
  static const std::vector<std::string> names = {"cp", "bt", "basic", "l2"};
  return names;
}

const std::vector<std::string>& NewtonOptions::near_null_spaces()
{
  static const std::vector<std::string> names = {"bodies", "global"};
  return names;
}

void NewtonOptions::validate() const
{
  auto check = [](const char* option, const std::string& value,
                  const std::vector<std::string>& allowed)
  {
    if (std::find(allowed.begin(), allowed.end(), value) == allowed.end())
      throw InputError(std::string(option) + " '" + value + "' is not allowed; allowed: "
                       + join(allowed) + did_you_mean(value, allowed));
  };
  check("linear solver", linear_solver, linear_solvers());
  check("line search", line_search, line_searches());
  check("near-null space", near_null_space, near_null_spaces());
  if (!(rtol > 0 and atol > 0 and linear_rtol > 0 and linear_rtol < 1))
    throw InputError("Newton tolerances must be > 0 and the linear rtol below 1");
  if (!(creep_window >= 0 and creep_step >= 0 and creep_step < 1))
    throw InputError("the creep guard needs a window >= 0 and a step length in [0, 1)");
}

} // namespace muscle
