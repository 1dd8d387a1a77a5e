// What holds the body: boundary conditions and ties between surfaces.
#include "scene/scene_sections.h"

#include "common/errors.h"

namespace muscle::scene_input
{
namespace
{
BoundaryCondition read_condition(const Entry& e)
{
  const std::vector<std::string> kinds = {"clamp", "displacement", "uniform_axial", "fix_point"};
  if (!e.is_map())
    e.fail("expected a condition (" + join(kinds) + ": SURFACE, ...), found " + e.shown());
  const std::string kind = e.one_of(kinds);
  BoundaryCondition bc;
  bc.where = e.where();
  if (kind == "fix_point")
  {
    e.require_map({"fix_point"});
    bc.kind = BoundaryCondition::Kind::point;
    bc.at = vector3(e["fix_point"], "the reference coordinates in mm");
    return bc;
  }
  bc.surface = e[kind].text();
  if (kind == "clamp")
  {
    e.require_map({"clamp"});
    bc.kind = BoundaryCondition::Kind::clamp;
  }
  else if (kind == "displacement")
  {
    e.require_map({"displacement", "component", "value"});
    bc.kind = BoundaryCondition::Kind::displacement;
    bc.component = parse_component(e.required("component"));
    bc.value = time_function(e.required("value"), false);
  }
  else
  {
    e.require_map({"uniform_axial", "component"});
    bc.kind = BoundaryCondition::Kind::uniform_axial;
    bc.component = parse_component(e.required("component"));
  }
  return bc;
}

} // namespace

void read_boundary(const Entry& top, Scene& scene)
{
  // a dynamic body may fly free: its inertia makes the Newton system regular
  const Entry b = top.required("boundary");
  if (!b.is_sequence() or (b.size() == 0 and !top["dynamics"].defined()))
    b.fail("expected a list of conditions (clamp, displacement, uniform_axial), found "
           + b.shown() + (b.is_sequence() ? " (only a dynamic scene may have none)" : ""));
  for (std::size_t i = 0; i < b.size(); ++i)
    scene.boundary.push_back(read_condition(b.at(i)));
}

void read_ties(const Entry& top, Scene& scene)
{
  const Entry ties = top["tie"];
  if (!list_given(ties, "ties ({surfaces: [SLAVE, MASTER]})"))
    return;
  for (std::size_t i = 0; i < ties.size(); ++i)
  {
    const Entry t = ties.at(i);
    t.require_map({"surfaces", "tolerance"});
    const auto [slave, master] = surface_pair(
        t.required("surfaces"), "the slave surface's nodes follow the master surface",
        "a surface cannot be tied to itself");
    TieSpec tie{slave, master, -1, t.where()};
    if (t["tolerance"].defined())
      tie.tolerance = t["tolerance"].positive(0);
    scene.ties.push_back(tie);
  }
}

void check_uniform_axial(const Scene& scene)
{
  int constraints = 0;
  for (const BoundaryCondition& bc : scene.boundary)
    if (bc.kind == BoundaryCondition::Kind::uniform_axial and ++constraints > 1)
      throw InputError(bc.where.text() + ": only one uniform_axial condition per scene");
}

} // namespace muscle::scene_input
