// Penalty contact between pairs of surfaces.
#include "scene/scene_sections.h"

namespace muscle::scene_input
{

void read_contacts(const Entry& top, Scene& scene)
{
  const Entry contacts = top["contact"];
  if (!list_given(contacts, "contact pairs ({surfaces: [SLAVE, MASTER], penalty: EPS})"))
    return;
  for (std::size_t i = 0; i < contacts.size(); ++i)
  {
    const Entry c = contacts.at(i);
    c.require_map({"surfaces", "penalty", "normals"});
    const auto [slave, master] = surface_pair(
        c.required("surfaces"), "the slave surface's points are kept out of the master surface",
        "a surface in contact with itself is not supported");
    ContactSpec spec{slave, master, -1, true, c.where()};
    if (c["penalty"].defined())
      spec.penalty = c["penalty"].positive(0);
    if (c["normals"].defined())
      spec.smooth_normals = c["normals"].choice({"smooth", "facet"}) == "smooth";
    scene.contacts.push_back(spec);
  }
}

} // namespace muscle::scene_input
