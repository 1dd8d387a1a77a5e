// External loads: pressure, traction and gravity, each scaled in time.
#include "scene/scene_sections.h"

#include "common/errors.h"

#include <algorithm>

namespace muscle::scene_input
{
namespace
{
LoadSpec read_load(const Entry& e)
{
  const std::vector<std::string> kinds = {"pressure", "traction", "gravity"};
  if (!e.is_map())
    e.fail("expected a load (" + join(kinds) + ": ..., value: TIME FUNCTION), found " + e.shown());
  const std::string kind = e.one_of(kinds);
  LoadSpec l;
  l.where = e.where();
  l.kind = static_cast<LoadSpec::Kind>(std::find(kinds.begin(), kinds.end(), kind)
                                       - kinds.begin());
  if (kind == "pressure")
  {
    e.require_map({"pressure", "value"});
    l.surface = e["pressure"].text();
    l.value = time_function(e.required("value"), false);
  }
  else
  {
    e.require_map({kind.c_str(), "vector", "value"});
    if (kind == "traction")
    {
      l.surface = e["traction"].text();
      l.vector = vector3(e.required("vector"), "the traction in kPa");
    }
    else
      l.vector = vector3(e["gravity"], "the acceleration of gravity in mm/s^2");
    if (e["value"].defined())
      l.value = time_function(e["value"], false);
    else
    {
      l.value.kind = TimeFunction::Kind::constant;
      l.value.value = 1;
    }
  }
  return l;
}

} // namespace

void read_loads(const Entry& top, Scene& scene)
{
  const Entry loads = top["loads"];
  if (!list_given(loads, "loads (pressure, traction, gravity)"))
    return;
  for (std::size_t i = 0; i < loads.size(); ++i)
  {
    scene.loads.push_back(read_load(loads.at(i)));
    if (scene.loads.back().kind == LoadSpec::Kind::gravity)
      for (std::size_t p = 0; p < scene.parts.size(); ++p)
        if (!(scene.parts[p].density > 0))
          loads.at(i).fail("gravity needs the density of every part: parts[" + std::to_string(p)
                           + "] ('" + scene.parts[p].name + "') has none ('density: "
                           "RHO' in kg/mm^3; 1 g/cm^3 = 1e-6)");
  }
}

} // namespace muscle::scene_input
