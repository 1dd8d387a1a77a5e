// The Newton solver, its linear solver, PETSc options and the activation's
// root finder.
#include "scene/scene_sections.h"

#include <sstream>

namespace muscle::scene_input
{
namespace
{
void read_petsc_options(const Entry& e, std::vector<std::string>& options)
{
  std::istringstream words(e.text());
  for (std::string w; words >> w;)
    options.push_back(w);
  if (!options.empty() and options[0][0] != '-')
    e.fail("PETSc options start with '-', e.g. \"-snes_monitor -ksp_type gmres\"");
}
} // namespace

void read_solver(const Entry& top, Scene& scene)
{
  const Entry s = top["solver"];
  if (!s.defined())
    return;
  s.require_map({"linear", "line_search", "rtol", "atol", "max_iterations",
                 "stagnation_window", "creep_window", "linear_rtol", "fbar_cell_unknowns", "root_tolerance",
                 "near_null_space", "reduced_blocks", "petsc"});
  NewtonOptions& newton = scene.newton;
  newton.linear_solver
      = s["linear"].defined() ? s["linear"].choice(NewtonOptions::linear_solvers()) : "lu";
  if (s["line_search"].defined())
  {
    newton.line_search = s["line_search"].choice(NewtonOptions::line_searches());
    scene.line_search_given = true;
  }
  newton.rtol = s["rtol"].positive(newton.rtol);
  newton.atol = s["atol"].positive(newton.atol);
  newton.max_iterations = s["max_iterations"].integer(25, 1, 1000);
  newton.stagnation_window = s["stagnation_window"].integer(newton.stagnation_window, 0, 1000);
  newton.creep_window = s["creep_window"].integer(newton.creep_window, 0, 1000);
  newton.linear_rtol = s["linear_rtol"].positive(newton.linear_rtol);
  newton.fbar_cell_unknowns = s["fbar_cell_unknowns"].flag(true);
  if (s["near_null_space"].defined())
    newton.near_null_space = s["near_null_space"].choice(NewtonOptions::near_null_spaces());
  newton.reduced_blocks = s["reduced_blocks"].flag(true);
  scene.root_tolerance = s["root_tolerance"].number(scene.root_tolerance);
  if (!(scene.root_tolerance >= 1e-16 and scene.root_tolerance < 1))
    s["root_tolerance"].fail("'" + s["root_tolerance"].text() + "' must be from 1e-16 "
                             "(round-off; smaller never stops) to below 1");
  if (s["petsc"].defined())
    read_petsc_options(s["petsc"], scene.petsc_options);
}

} // namespace muscle::scene_input
