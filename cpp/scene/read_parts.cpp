// A scene's parts: each one's material law and parameters, fibre directions
// and activation in time and space.
#include "scene/scene_sections.h"

#include "common/errors.h"
#include "forms/form_registry.h"

#include <set>

namespace muscle::scene_input
{
namespace
{
void read_material(const Entry& e, Part& part, const std::string& directory)
{
  e.require_map({"model", "parameters", "parameter_file", "active"});
  std::vector<std::string> models;
  for (const Model& m : all_models())
    models.push_back(m.name());
  const Entry model = e.required("model");
  part.parameters = ParameterSet(parse_model(model.choice(models)));
  part.active = e["active"].flag(true);
  if (e["parameter_file"].defined())
  {
    const Entry f = e["parameter_file"];
    try
    {
      read_parameter_file(existing_file(f, directory), part.parameters);
    }
    catch (const InputError& error)
    {
      throw InputError(std::string(error.what()) + " (read for " + f.where().text() + ")");
    }
  }
  const Entry p = e["parameters"];
  if (p.defined())
  {
    p.require_map(part.parameters.names());
    for (const std::string& name : p.keys())
      part.parameters.set(name, p[name].number());
  }
  try
  {
    part.parameters.validate();
  }
  catch (const InputError& error)
  {
    // at the offending value where the scene (or a --set) gave it
    const std::string message = error.what();
    if (p.defined())
      for (const std::string& name : p.keys())
        if (message.rfind("parameter " + name + " = ", 0) == 0)
          p[name].fail(message);
    (p.defined() ? p : e).fail(message);
  }
}

FibreSpec read_fibres(const Entry& e, const std::string& directory)
{
  FibreSpec f;
  f.where = e.where();
  if (!e.defined())
    return f; // along z
  e.require_map({"direction", "laplace", "file"});
  const std::string kind = e.one_of({"direction", "laplace", "file"});
  const Entry v = e[kind];
  if (kind == "direction")
  {
    f.kind = FibreSpec::Kind::direction;
    if (!v.is_sequence() or v.size() != 3)
      v.fail("expected [a1, a2, a3], found " + v.shown());
    for (int i = 0; i < 3; ++i)
      f.direction[i] = v.at(i).number();
    if (f.direction[0] == 0 and f.direction[1] == 0 and f.direction[2] == 0)
      v.fail("the fibre direction must not be zero");
  }
  else if (kind == "laplace")
  {
    f.kind = FibreSpec::Kind::laplace;
    v.require_map({"from", "to"});
    f.from = v.required("from").text();
    f.to = v.required("to").text();
    if (f.from == f.to)
      v["to"].fail("'from' and 'to' must be different surfaces");
  }
  else
  {
    f.kind = FibreSpec::Kind::file;
    f.path = existing_file(v, directory);
  }
  f.where = v.where();
  return f;
}

ActivationScale read_scale(const Entry& e, const std::string& directory)
{
  ActivationScale s;
  s.where = e.where();
  if (!e.defined())
    return s;
  if (e.is_scalar())
  {
    s.value = e.number();
    if (s.value < 0)
      e.fail("'" + e.text() + "' must be >= 0");
    return s;
  }
  e.require_map({"constant", "groups", "other", "expression", "file"});
  const std::string kind = e.one_of({"constant", "groups", "expression", "file"});
  const Entry v = e[kind];
  s.where = v.where();
  if (kind == "constant")
    s.value = v.number();
  else if (kind == "groups")
  {
    s.kind = ActivationScale::Kind::groups;
    if (!v.is_map())
      v.fail("expected a mapping 'volume group: scale', found " + v.shown());
    for (const std::string& name : v.keys())
    {
      s.groups[name] = v[name].number();
      if (s.groups[name] < 0)
        v[name].fail("'" + v[name].text() + "' must be >= 0");
    }
    s.other = e["other"].number(0);
    if (s.other < 0)
      e["other"].fail("'" + e["other"].text() + "' must be >= 0");
  }
  else if (kind == "expression")
  {
    s.kind = ActivationScale::Kind::expression;
    s.formula = expression(v, {"x", "y", "z", "t"});
  }
  else
  {
    s.kind = ActivationScale::Kind::file;
    s.path = existing_file(v, directory);
  }
  if (kind != "groups" and e["other"].defined())
    e["other"].fail("'other' goes with 'groups' only");
  if (s.value < 0)
    v.fail("'" + v.text() + "' must be >= 0");
  return s;
}

Part read_part(const Entry& e, const std::string& directory)
{
  e.require_map({"name", "volumes", "material", "fibres", "activation", "density"});
  Part part;
  part.where = e.where();
  part.name = e["name"].text("muscle");
  if (e["density"].defined())
    part.density = e["density"].positive(0);
  const Entry v = e["volumes"];
  if (v.defined())
  {
    if (v.is_scalar())
      part.volumes.push_back(v.text());
    else if (v.is_sequence() and v.size() > 0)
      for (std::size_t i = 0; i < v.size(); ++i)
        part.volumes.push_back(v.at(i).text());
    else
      v.fail("expected a volume group name or a non-empty list of them, found " + v.shown());
  }
  read_material(e.required("material"), part, directory);
  part.fibres = read_fibres(e["fibres"], directory);
  const Entry a = e["activation"];
  if (a.defined())
  {
    a.require_map({"time", "scale"});
    if (!part.active)
      a.fail("a passive part (material.active: false) has no activation; remove this "
             "entry or set active: true");
    if (a["time"].defined())
      part.activation_time = time_function(a["time"], true);
    part.activation_scale = read_scale(a["scale"], directory);
  }
  return part;
}

void check_anti_locking(const Entry& el, const MeshSpec& mesh, const Part& part)
{
  const int vq = mesh.volumetric_quadrature_degree;
  // the defaults are the same on hexahedra and tetrahedra
  const int q = mesh.quadrature_degree >= 0
                    ? mesh.quadrature_degree
                    : forms::default_quadrature_degree("hexahedron", mesh.degree);
  if (vq >= 0 and vq != q and !part.parameters.model().law().anti_locking)
    el["volumetric_quadrature_degree"].fail(
        "the anti-locking element (a volumetric quadrature degree of its own) is "
        "compiled for the laws whose file gives volumetric_stiff_part (BLE), part '"
        + part.name + "' is " + to_string(part.parameters.model())
        + "; use fbar: true or degree 2 (docs/scenes.md)");
}
} // namespace

void read_parts(const Entry& top, const std::string& directory, Scene& scene)
{
  const Entry el = top["element"];
  const Entry parts = top.required("parts");
  if (!parts.is_sequence() or parts.size() == 0)
    parts.fail("expected a list of parts, found " + parts.shown());
  std::set<std::string> part_names;
  for (std::size_t i = 0; i < parts.size(); ++i)
  {
    scene.parts.push_back(read_part(parts.at(i), directory));
    if (parts.size() > 1 and scene.parts.back().volumes.empty())
      parts.at(i).fail("with several parts, each names its volume groups ('volumes: [...]')");
    if (!part_names.insert(scene.parts.back().name).second)
      parts.at(i)["name"].fail("two parts named '" + scene.parts.back().name + "'");
    check_anti_locking(el, scene.mesh, scene.parts.back());
  }
}

} // namespace muscle::scene_input
