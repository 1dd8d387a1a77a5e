// What a run writes: the quantities of series.csv, fields, plots and
// checkpoints.
#include "scene/scene_sections.h"

#include <algorithm>
#include <set>

namespace muscle::scene_input
{
namespace
{
/// Where a quantity is measured: on a surface, of a part, at a point, or
/// over the whole body (then no surface or component may be given).
void read_place(const Entry& e, const std::string& kind, SeriesQuantity& q)
{
  const bool on_surface = kind == "reaction" or kind == "section_force"
                          or kind == "displacement" or kind == "stretch_ratio";
  if (on_surface)
  {
    q.surface = e.required("surface").text();
    q.component = parse_component(e.required("component"));
  }
  else if (kind == "rotation")
  {
    if (e["surface"].defined())
      e["surface"].fail("'rotation' is the rotation of a part ('part: NAME'); remove 'surface'");
    q.part = e.required("part").text();
    q.component = parse_component(e.required("component"));
  }
  else if (kind == "point")
  {
    if (e["surface"].defined())
      e["surface"].fail("'point' is measured at a point ('at: [x, y, z]'); remove 'surface'");
    q.component = parse_component(e.required("component"));
    const Entry at = e.required("at");
    if (!at.is_sequence() or at.size() != 3)
      at.fail("expected the reference coordinates [x, y, z] in mm, found " + at.shown());
    for (std::size_t d = 0; d < 3; ++d)
      q.at[d] = at.at(d).number();
    q.position = e["of"].defined() and e["of"].choice({"displacement", "position"}) == "position";
  }
  else
    for (const char* k : {"surface", "component"})
      if (e[k].defined())
        e[k].fail("'" + kind + "' is not measured on a surface; remove '" + k + "'");
}

/// The keys that only some kinds of quantity take.
void read_kind_options(const Entry& e, const std::string& kind, SeriesQuantity& q)
{
  if (kind != "rotation" and e["part"].defined())
    e["part"].fail("'part' goes with the rotation quantity only");
  if (kind != "point")
    for (const char* k : {"at", "of"})
      if (e[k].defined())
        e[k].fail("'" + std::string(k) + "' goes with the point quantity only");
  const bool contact = kind == "contact_force" or kind == "contact_area"
                       or kind == "max_pressure" or kind == "max_penetration";
  if (contact)
    q.pair = e["pair"].integer(0, 0, 1000);
  else if (e["pair"].defined())
    e["pair"].fail("'pair' goes with the contact quantities only");
  if (kind == "stretch_ratio")
    q.length = e.required("length").positive(1);
  else if (e["length"].defined())
    e["length"].fail("'length' goes with stretch_ratio only");
  if (kind == "section_force")
    q.sign = e["side"].defined() and e["side"].choice({"below", "above"}) == "above" ? -1 : 1;
  else if (e["side"].defined())
    e["side"].fail("'side' goes with section_force only");
}

SeriesQuantity read_quantity(const Entry& e)
{
  e.require_map(
      {"name", "quantity", "surface", "component", "length", "side", "at", "of", "pair", "part"});
  SeriesQuantity q;
  q.where = e.where();
  // in the order of SeriesQuantity::Kind
  const std::vector<std::string> kinds = {"activation",      "reaction",      "section_force",
                                          "displacement",    "stretch_ratio", "volume_change",
                                          "min_J",           "point",         "contact_force",
                                          "contact_area",    "max_pressure",  "max_penetration",
                                          "rotation",        "kinetic_energy", "strain_energy"};
  const std::string kind = e.required("quantity").choice(kinds);
  q.kind = static_cast<SeriesQuantity::Kind>(
      std::find(kinds.begin(), kinds.end(), kind) - kinds.begin());
  q.name = e["name"].text(kind);
  read_place(e, kind, q);
  read_kind_options(e, kind, q);
  return q;
}
} // namespace

void read_output(const Entry& top, OutputSpec& output)
{
  const Entry o = top["output"];
  if (!o.defined())
    return;
  o.require_map({"series", "fields", "fields_every", "plots", "surface", "checkpoint_every"});
  if (const Entry q = o["series"]; list_given(q, "quantities"))
  {
    std::set<std::string> names;
    for (std::size_t i = 0; i < q.size(); ++i)
    {
      output.series.push_back(read_quantity(q.at(i)));
      if (!names.insert(output.series.back().name).second)
        q.at(i)["name"].fail("two columns named '" + output.series.back().name + "'");
    }
  }
  output.fields = o["fields"].flag(true);
  output.fields_every = o["fields_every"].integer(1, 1, 1000000);
  output.plots = o["plots"].flag(true);
  output.surface = o["surface"].flag(true);
  output.checkpoint_every = o["checkpoint_every"].integer(1, 1, 1000000);
}

} // namespace muscle::scene_input
