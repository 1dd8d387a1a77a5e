#include "nonlinear_solver.h"

#include "../common/errors.h"

#include <algorithm>

namespace muscle
{

const std::vector<std::string>& NewtonOptions::linear_solvers()
{
  static const std::vector<std::string> names = {"lu", "gmres-hypre", "gmres-gamg",
                                                     "gmres-schur", "gmres-stars"};
  return names;
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
}

} // namespace muscle
