// Time stepping, and the dynamics that make a scene's time physical.
#include "scene/scene_sections.h"

namespace muscle::scene_input
{

void read_time(const Entry& top, TimeSteppingOptions& time)
{
  const Entry t = top.required("time");
  t.require_map({"end", "step", "max_cutbacks", "cutback_factor", "growth_factor"});
  time.t_end = t.required("end").positive(0);
  time.dt = t.required("step").positive(0);
  if (time.dt > time.t_end)
    t["step"].fail("'" + t["step"].text() + "' is longer than the simulated time");
  time.max_cutbacks = t["max_cutbacks"].integer(8, 0, 40);
  time.cutback_factor = t["cutback_factor"].number(0.5);
  if (!(time.cutback_factor > 0 and time.cutback_factor < 1))
    t["cutback_factor"].fail("'" + t["cutback_factor"].text() + "' must be between 0 and 1");
  time.growth_factor = t["growth_factor"].number(1.5);
  if (!(time.growth_factor >= 1))
    t["growth_factor"].fail("'" + t["growth_factor"].text() + "' must be >= 1");
}

void read_dynamics(const Entry& top, Scene& scene)
{
  const Entry d = top["dynamics"];
  if (!d.defined())
    return;
  d.require_map({"method", "rho_inf", "initial_velocity"});
  if (d["method"].defined())
    d["method"].choice({"generalized_alpha"});
  DynamicsSpec dynamics;
  dynamics.where = d.where();
  dynamics.rho_inf = d["rho_inf"].number(1);
  if (const Entry v = d["initial_velocity"]; v.defined())
  {
    if (!v.is_sequence() or v.size() != 3)
      v.fail("expected a velocity [vx, vy, vz] in mm/s, found " + v.shown());
    for (std::size_t k = 0; k < 3; ++k)
      dynamics.initial_velocity[k] = v.at(k).number();
  }
  if (!(dynamics.rho_inf >= 0 and dynamics.rho_inf <= 1))
    d["rho_inf"].fail("'" + d["rho_inf"].text() + "' is outside [0, 1] (the spectral radius "
                      "at infinite frequency: 1 damps nothing, 0 the most)");
  for (std::size_t p = 0; p < scene.parts.size(); ++p)
    if (!(scene.parts[p].density > 0))
      d.fail("a dynamic scene needs the density of every part: parts[" + std::to_string(p)
             + "] ('" + scene.parts[p].name + "') has none ('density: RHO' in kg/mm^3; "
             "1 g/cm^3 = 1e-6)");
  scene.dynamics = dynamics;
}

} // namespace muscle::scene_input
