// Functions of time in a scene (activation, prescribed displacements, loads):
// read from the file and evaluated during the run.
#include "scene/scene_sections.h"

#include "common/errors.h"

#include <algorithm>

namespace muscle
{

double TimeFunction::operator()(double t, double model_factor) const
{
  switch (kind)
  {
  case Kind::model:
    return model_factor;
  case Kind::constant:
    return value;
  case Kind::ramp:
    if (duration <= 0)
      return t >= start ? value : 0.0;
    return value * std::clamp((t - start) / duration, 0.0, 1.0);
  case Kind::table:
  {
    if (t <= table.front()[0])
      return table.front()[1];
    for (std::size_t k = 1; k < table.size(); ++k)
      if (t <= table[k][0])
      {
        const double s = (t - table[k - 1][0]) / (table[k][0] - table[k - 1][0]);
        return (1 - s) * table[k - 1][1] + s * table[k][1];
      }
    return table.back()[1];
  }
  default:
    return (*formula)(&t);
  }
}

namespace scene_input
{
namespace
{
void read_ramp(const Entry& v, TimeFunction& f)
{
  f.kind = TimeFunction::Kind::ramp;
  v.require_map({"start", "duration", "value"});
  f.start = v["start"].number(0);
  f.duration = v["duration"].number(0);
  if (f.duration < 0)
    v["duration"].fail("'" + v["duration"].text() + "' must be >= 0");
  f.value = v.required("value").number();
}

void read_table(const Entry& v, TimeFunction& f)
{
  f.kind = TimeFunction::Kind::table;
  if (!v.is_sequence() or v.size() == 0)
    v.fail("expected a list of [t, value] pairs, found " + v.shown());
  for (std::size_t i = 0; i < v.size(); ++i)
  {
    const Entry row = v.at(i);
    if (!row.is_sequence() or row.size() != 2)
      row.fail("expected [t, value], found " + row.shown());
    const double t = row.at(0).number();
    if (!f.table.empty() and !(t > f.table.back()[0]))
      row.at(0).fail("times must increase (" + row.at(0).text() + " after "
                     + std::to_string(f.table.back()[0]) + ")");
    f.table.push_back({t, row.at(1).number()});
  }
}
} // namespace

TimeFunction time_function(const Entry& e, bool allow_model)
{
  TimeFunction f;
  if (e.is_scalar())
  {
    if (e.text() == "model")
    {
      if (!allow_model)
        e.fail("'model' (the material's own activation) is only allowed for activation.time");
      return f;
    }
    f.kind = TimeFunction::Kind::constant;
    f.value = e.number();
    return f;
  }
  std::vector<std::string> kinds = {"constant", "ramp", "table", "expression"};
  if (allow_model)
    kinds.insert(kinds.begin(), "model");
  if (!e.is_map())
    e.fail("expected a time function (" + join(kinds) + "), found " + e.shown());
  e.require_map(kinds);
  const std::string kind = e.one_of(kinds);
  const Entry v = e[kind];
  if (kind == "model")
    return f;
  if (kind == "constant")
  {
    f.kind = TimeFunction::Kind::constant;
    f.value = v.number();
  }
  else if (kind == "ramp")
    read_ramp(v, f);
  else if (kind == "table")
    read_table(v, f);
  else
  {
    f.kind = TimeFunction::Kind::expression;
    f.formula = expression(v, {"t"});
  }
  return f;
}

} // namespace scene_input
} // namespace muscle
