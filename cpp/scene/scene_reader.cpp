// Scene files: YAML -> Scene, with every mistake reported as
// "FILE:LINE: KEY: what is wrong; what is allowed".
#include "scene/scene.h"

#include "common/errors.h"
#include "fem/elements/element_choice.h"
#include "forms/form_registry.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <yaml-cpp/yaml.h>

namespace muscle
{

std::string SceneLocation::text() const
{
  std::string s = file;
  if (line > 0)
    s += ":" + std::to_string(line);
  if (!key.empty())
    s += ": " + key;
  return s;
}

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

namespace
{
/// Where a scene's values come from: the file, and the command line's
/// `--set KEY=VALUE` for the keys it replaced.
struct Source
{
  std::string file;
  std::map<std::string, std::string> overrides; ///< dotted key -> "--set KEY=VALUE"
};

/// A YAML node and where it is: every accessor checks and reports in place.
class Entry
{
public:
  Entry(YAML::Node node, std::string key, const Source& source, int parent_line)
      : _node(node), _key(std::move(key)), _source(source),
        _line(node.IsDefined() and node.Mark().line >= 0 ? node.Mark().line + 1
                                                         : parent_line)
  {
    if (auto it = source.overrides.find(_key); it != source.overrides.end())
    {
      _origin = &it->second;
      _line = 0;
    }
  }

  bool defined() const { return _node.IsDefined() and !_node.IsNull(); }
  bool is_map() const { return _node.IsMap(); }
  bool is_sequence() const { return _node.IsSequence(); }
  bool is_scalar() const { return _node.IsScalar(); }
  const std::string& key() const { return _key; }

  SceneLocation where() const { return {_origin ? *_origin : _source.file, _line, _key}; }

  [[noreturn]] void fail(const std::string& what) const
  {
    throw InputError(where().text() + ": " + what);
  }

  std::string shown() const
  {
    if (_node.IsScalar())
      return "'" + _node.Scalar() + "'";
    if (_node.IsSequence())
      return "a list";
    if (_node.IsMap())
      return "a mapping";
    return "nothing";
  }

  /// Child of a mapping; `allowed` lists every key this mapping may have.
  Entry operator[](const std::string& name) const
  {
    return Entry(_node.IsMap() ? _node[name] : YAML::Node(YAML::NodeType::Undefined),
                 _key.empty() ? name : _key + "." + name, _source, _line);
  }

  Entry at(std::size_t i) const
  {
    return Entry(_node[i], _key + "[" + std::to_string(i) + "]", _source, _line);
  }
  std::size_t size() const { return _node.size(); }

  /// A mapping whose keys are all in `allowed`.
  const Entry& require_map(const std::vector<std::string>& allowed) const
  {
    if (!_node.IsMap())
      fail("expected a mapping with keys " + join(allowed) + ", found " + shown());
    for (auto it = _node.begin(); it != _node.end(); ++it)
    {
      if (!it->first.IsScalar())
        fail("keys must be names");
      const std::string k = it->first.Scalar();
      if (std::find(allowed.begin(), allowed.end(), k) == allowed.end())
      {
        Entry child(it->second, _key.empty() ? k : _key + "." + k, _source,
                    it->first.Mark().line + 1);
        child.fail("unknown key '" + k + "'" + did_you_mean(k, allowed)
                   + "; allowed here: " + join(allowed));
      }
    }
    return *this;
  }

  std::vector<std::string> keys() const
  {
    std::vector<std::string> k;
    if (_node.IsMap())
      for (auto it = _node.begin(); it != _node.end(); ++it)
        k.push_back(it->first.Scalar());
    return k;
  }

  /// The one key present out of alternatives (e.g. clamp | displacement).
  std::string one_of(const std::vector<std::string>& alternatives) const
  {
    std::string found;
    for (const std::string& k : keys())
      if (std::find(alternatives.begin(), alternatives.end(), k) != alternatives.end())
      {
        if (!found.empty())
          fail("give only one of " + join(alternatives) + " (found '" + found + "' and '" + k
               + "')");
        found = k;
      }
    if (found.empty())
      fail("expected one of " + join(alternatives));
    return found;
  }

  std::string text() const
  {
    if (!_node.IsScalar())
      fail("expected a text value, found " + shown());
    return _node.Scalar();
  }
  std::string text(const std::string& fallback) const
  {
    return defined() ? text() : fallback;
  }

  std::string choice(const std::vector<std::string>& allowed) const
  {
    const std::string v = text();
    if (std::find(allowed.begin(), allowed.end(), v) == allowed.end())
      fail("'" + v + "' is not allowed; allowed: " + join(allowed) + did_you_mean(v, allowed));
    return v;
  }

  double number() const
  {
    if (!_node.IsScalar())
      fail("expected a number, found " + shown());
    const std::string& s = _node.Scalar();
    if (!parse_real(s, false))
      fail("'" + s + "' is not a number");
    const auto v = parse_real(s);
    if (!v)
      fail("'" + s + "' is not a finite number");
    return *v;
  }
  double number(double fallback) const { return defined() ? number() : fallback; }

  double positive(double fallback) const
  {
    const double v = number(fallback);
    if (!(v > 0))
      fail("'" + text() + "' must be > 0");
    return v;
  }

  int integer(int fallback, int lower, int upper) const
  {
    if (!defined())
      return fallback;
    const double v = number();
    if (v != std::floor(v) or v < lower or v > upper)
      fail("'" + text() + "' must be an integer from " + std::to_string(lower) + " to "
           + std::to_string(upper));
    return static_cast<int>(v);
  }

  bool flag(bool fallback) const
  {
    if (!defined())
      return fallback;
    const std::string v = text();
    if (v == "true" or v == "yes" or v == "on")
      return true;
    if (v == "false" or v == "no" or v == "off")
      return false;
    fail("'" + v + "' is not allowed; allowed: true, false");
  }

  Entry required(const std::string& name) const
  {
    Entry e = (*this)[name];
    if (!e.defined())
      fail("missing key '" + name + "'");
    return e;
  }

private:
  YAML::Node _node;
  std::string _key;
  const Source& _source;
  const std::string* _origin = nullptr; ///< the --set that gave the value, if one did
  int _line;
};

/// One step of a dotted scene path: a key, or an index into a list.
struct PathStep
{
  std::string key;
  long index = -1;
};

/// "parts[0].material.parameters.kappa" -> parts, [0], material, parameters, kappa
std::vector<PathStep> split_path(const std::string& path, const std::string& origin)
{
  std::vector<PathStep> steps;
  std::size_t i = 0;
  auto bad = [&](const std::string& what) -> InputError
  { return InputError(origin + ": " + what + "; a key is a dotted path such as "
                      "parts[0].material.parameters.kappa or time.step"); };
  while (i < path.size())
  {
    const std::size_t end = path.find_first_of(".[", i);
    const std::string key = path.substr(i, end == std::string::npos ? end : end - i);
    if (key.empty())
      throw bad("empty name in '" + path + "'");
    steps.push_back({key});
    i = end == std::string::npos ? path.size() : end;
    while (i < path.size() and path[i] == '[')
    {
      const std::size_t close = path.find(']', i);
      const std::string digits
          = path.substr(i + 1, close == std::string::npos ? close : close - i - 1);
      if (close == std::string::npos or digits.empty()
          or digits.find_first_not_of("0123456789") != std::string::npos or digits.size() > 6)
        throw bad("'" + path.substr(i) + "' is not a list index [N]");
      steps.push_back({"", std::stol(digits)});
      i = close + 1;
    }
    if (i < path.size())
    {
      if (path[i] != '.' or i + 1 == path.size())
        throw bad("unexpected '" + path.substr(i) + "'");
      ++i;
    }
  }
  if (steps.empty())
    throw bad("no key");
  return steps;
}

/// Replace (or add) the value at a dotted path of the scene's YAML tree.  A
/// key that the scene may not have is left to the reader, which names the
/// nearest valid one; a path through a missing list or a scalar stops here.
void apply_override(YAML::Node& root, const std::string& assignment, Source& source)
{
  const std::string origin = "--set " + assignment;
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos)
    throw InputError(origin + ": expected KEY=VALUE, e.g. time.step=0.01");
  const std::string path = assignment.substr(0, eq);
  const std::vector<PathStep> steps = split_path(path, origin);
  YAML::Node value;
  try
  {
    value = YAML::Load(assignment.substr(eq + 1));
  }
  catch (const YAML::Exception& e)
  {
    throw InputError(origin + ": the value is not valid YAML: " + e.msg);
  }
  if (!value.IsDefined() or value.IsNull())
    throw InputError(origin + ": no value after '='");

  YAML::Node node;
  node.reset(root);
  std::string reached; // the dotted path walked so far, for messages
  for (std::size_t k = 0; k < steps.size(); ++k)
  {
    const PathStep& s = steps[k];
    const bool last = k + 1 == steps.size();
    const std::string here = s.index >= 0 ? reached + "[" + std::to_string(s.index) + "]"
                                          : (reached.empty() ? s.key : reached + "." + s.key);
    if (s.index >= 0)
    {
      if (!node.IsSequence())
        throw InputError(origin + ": '" + reached + "' is not a list in the scene");
      if (s.index >= static_cast<long>(node.size()))
        throw InputError(origin + ": '" + reached + "' has " + std::to_string(node.size())
                         + " items, so " + here + " does not exist (indices start at 0)");
      if (last)
        node[s.index] = value;
      else
      {
        YAML::Node child = node[s.index];
        node.reset(child);
      }
    }
    else
    {
      if (node.IsNull() or !node.IsDefined())
        node = YAML::Node(YAML::NodeType::Map);
      if (node.IsSequence())
        throw InputError(origin + ": '" + reached + "' is a list: name an item, " + reached
                         + "[N]." + s.key);
      if (!node.IsMap())
        throw InputError(origin + ": '" + reached + "' is a value, not a mapping with keys");
      if (last)
        node[s.key] = value;
      else
      {
        if (!node[s.key] and steps[k + 1].index >= 0)
        {
          std::vector<std::string> keys;
          for (auto it = node.begin(); it != node.end(); ++it)
            keys.push_back(it->first.Scalar());
          throw InputError(origin + ": the scene has no list '" + here + "'"
                           + did_you_mean(s.key, keys));
        }
        YAML::Node child = node[s.key];
        node.reset(child);
      }
    }
    reached = here;
  }
  source.overrides[path] = origin;
}

int parse_component(const Entry& e)
{
  const std::string c = e.choice({"x", "y", "z", "0", "1", "2"});
  return c == "x" or c == "0" ? 0 : c == "y" or c == "1" ? 1 : 2;
}

std::string resolve(const std::string& directory, const std::string& path)
{
  std::filesystem::path p(path);
  return p.is_absolute() ? path : (std::filesystem::path(directory) / p).lexically_normal().string();
}

std::string existing_file(const Entry& e, const std::string& directory)
{
  const std::string path = resolve(directory, e.text());
  std::error_code error; // a name the system refuses (too long, ...) is not found either
  if (!std::filesystem::is_regular_file(path, error))
    e.fail("file '" + e.text() + "' not found (looked for " + path + ")");
  return path;
}

Expression expression(const Entry& e, const std::vector<std::string>& variables)
{
  try
  {
    return Expression(e.text(), variables);
  }
  catch (const InputError& error)
  {
    e.fail(error.what());
  }
}

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
  {
    f.kind = TimeFunction::Kind::ramp;
    v.require_map({"start", "duration", "value"});
    f.start = v["start"].number(0);
    f.duration = v["duration"].number(0);
    if (f.duration < 0)
      v["duration"].fail("'" + v["duration"].text() + "' must be >= 0");
    f.value = v.required("value").number();
  }
  else if (kind == "table")
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
  else
  {
    f.kind = TimeFunction::Kind::expression;
    f.formula = expression(v, {"t"});
  }
  return f;
}

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

std::array<double, 3> vector3(const Entry& e, const std::string& what)
{
  if (!e.is_sequence() or e.size() != 3)
    e.fail("expected " + what + " [x, y, z], found " + e.shown());
  std::array<double, 3> v;
  for (std::size_t d = 0; d < 3; ++d)
    v[d] = e.at(d).number();
  return v;
}

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
  return q;
}
} // namespace

Scene parse_scene(const std::string& text, const std::string& name,
                  const std::string& directory, const std::vector<std::string>& overrides)
{
  YAML::Node root;
  try
  {
    root = YAML::Load(text);
  }
  catch (const YAML::Exception& e)
  {
    throw InputError(name + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  Scene scene;
  scene.file = name;
  scene.text = text;
  scene.overrides = overrides;
  Source source{name, {}};
  if (!overrides.empty() and !root.IsMap())
    throw InputError(name + ": a scene is a mapping; --set needs one");
  for (const std::string& assignment : overrides)
    apply_override(root, assignment, source);
  const Entry top(root, "", source, 1);
  if (!top.is_map())
    top.fail("a scene is a mapping with keys title, mesh, element, parts, boundary, time, "
             "solver, output; found " + top.shown());
  top.require_map(
      {"title", "mesh", "element", "parts", "boundary", "time", "dynamics", "solver", "output",
       "loads", "tie", "contact"});
  scene.title = top["title"].text(std::filesystem::path(name).stem().string());
  for (const char* k : {"element", "parts", "boundary", "loads", "tie", "contact", "dynamics"})
    scene.physics += std::string(k) + ":\n" + YAML::Dump(root[k]) + "\n";

  // mesh and element
  const Entry m = top.required("mesh");
  m.require_map({"file", "set"});
  scene.mesh.where = m.where();
  const Entry mf = m.required("file");
  scene.mesh.path = existing_file(mf, directory);
  const std::string ext = std::filesystem::path(scene.mesh.path).extension().string();
  if (ext != ".geo" and ext != ".msh")
    mf.fail("'" + mf.text() + "' must be a Gmsh .geo or .msh file");
  if (m["set"].defined())
  {
    if (!m["set"].is_map())
      m["set"].fail("expected a mapping NAME: NUMBER (Gmsh -setnumber), found "
                    + m["set"].shown());
    if (ext != ".geo")
      m["set"].fail("numbers can only be set for a .geo file");
    for (const std::string& k : m["set"].keys())
      scene.mesh.numbers[k] = m["set"][k].number();
    scene.mesh.numbers_where = m["set"].where();
  }
  // the mesh by its resolved path: a copy of the scene elsewhere still matches
  scene.physics += "mesh: " + scene.mesh.path + "\n";
  for (const auto& [k, v] : scene.mesh.numbers)
    scene.physics += k + "=" + std::to_string(v) + "\n";
  const Entry el = top["element"];
  if (el.defined())
  {
    el.require_map(
        {"degree", "quadrature_degree", "volumetric_quadrature_degree", "fbar", "taylor_hood"});
    scene.mesh.degree = el["degree"].integer(1, 1, 2);
    scene.mesh.quadrature_degree = el["quadrature_degree"].integer(-1, 1, 12);
    scene.mesh.volumetric_quadrature_degree
        = el["volumetric_quadrature_degree"].integer(-1, 1, 12);
    if (el["fbar"].defined())
    {
      scene.mesh.fbar = el["fbar"].flag(false);
      scene.mesh.fbar_where = el["fbar"].where();
      if (*scene.mesh.fbar)
        try
        {
          check_fbar_request(scene.mesh.degree, scene.mesh.volumetric_quadrature_degree >= 0);
        }
        catch (const InputError& e)
        {
          el["fbar"].fail(e.what());
        }
    }
    scene.mesh.taylor_hood = el["taylor_hood"].flag(false);
    if (scene.mesh.taylor_hood)
    {
      if (scene.mesh.degree != 2)
        el["taylor_hood"].fail("the Taylor-Hood element has a degree-2 displacement (Q2-Q1, "
                               "P2-P1): set element.degree: 2");
      if (scene.mesh.fbar.value_or(false) or scene.mesh.volumetric_quadrature_degree >= 0)
        el["taylor_hood"].fail("Taylor-Hood is an element of its own: not with fbar or "
                               "volumetric_quadrature_degree");
      if (scene.mesh.quadrature_degree >= 0)
        el["taylor_hood"].fail("Taylor-Hood is compiled with the default quadrature degree "
                               "(4); leave quadrature_degree out");
    }
  }

  // parts
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
    const int vq = scene.mesh.volumetric_quadrature_degree;
    // the defaults are the same on hexahedra and tetrahedra
    const int q = scene.mesh.quadrature_degree >= 0
                      ? scene.mesh.quadrature_degree
                      : forms::default_quadrature_degree("hexahedron", scene.mesh.degree);
    if (vq >= 0 and vq != q and !scene.parts.back().parameters.model().law().anti_locking)
      el["volumetric_quadrature_degree"].fail(
          "the anti-locking element (a volumetric quadrature degree of its own) is "
          "compiled for the laws whose file gives volumetric_stiff_part (BLE), part '"
          + scene.parts.back().name + "' is "
          + to_string(scene.parts.back().parameters.model())
          + "; use fbar: true or degree 2 (docs/scenes.md)");
  }

  // boundary conditions
  // a dynamic body may fly free: its inertia makes the Newton system regular
  const Entry b = top.required("boundary");
  if (!b.is_sequence() or (b.size() == 0 and !top["dynamics"].defined()))
    b.fail("expected a list of conditions (clamp, displacement, uniform_axial), found "
           + b.shown() + (b.is_sequence() ? " (only a dynamic scene may have none)" : ""));
  for (std::size_t i = 0; i < b.size(); ++i)
    scene.boundary.push_back(read_condition(b.at(i)));
  const Entry loads = top["loads"];
  if (loads.defined())
  {
    if (!loads.is_sequence())
      loads.fail("expected a list of loads (pressure, traction, gravity), found " + loads.shown());
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
  const Entry ties = top["tie"];
  if (ties.defined())
  {
    if (!ties.is_sequence())
      ties.fail("expected a list of ties ({surfaces: [SLAVE, MASTER]}), found " + ties.shown());
    for (std::size_t i = 0; i < ties.size(); ++i)
    {
      const Entry t = ties.at(i);
      t.require_map({"surfaces", "tolerance"});
      const Entry s = t.required("surfaces");
      if (!s.is_sequence() or s.size() != 2)
        s.fail("expected [SLAVE, MASTER]: the slave surface's nodes follow the master "
               "surface; found " + s.shown());
      TieSpec tie{s.at(0).text(), s.at(1).text(), -1, t.where()};
      if (tie.slave == tie.master)
        s.fail("a surface cannot be tied to itself");
      if (t["tolerance"].defined())
        tie.tolerance = t["tolerance"].positive(0);
      scene.ties.push_back(tie);
    }
  }
  const Entry contacts = top["contact"];
  if (contacts.defined())
  {
    if (!contacts.is_sequence())
      contacts.fail("expected a list of contact pairs ({surfaces: [SLAVE, MASTER], penalty: "
                    "EPS}), found " + contacts.shown());
    for (std::size_t i = 0; i < contacts.size(); ++i)
    {
      const Entry c = contacts.at(i);
      c.require_map({"surfaces", "penalty", "normals"});
      const Entry s = c.required("surfaces");
      if (!s.is_sequence() or s.size() != 2)
        s.fail("expected [SLAVE, MASTER]: the slave surface's points are kept out of the "
               "master surface; found " + s.shown());
      ContactSpec spec{s.at(0).text(), s.at(1).text(), -1, true, c.where()};
      if (spec.slave == spec.master)
        s.fail("a surface in contact with itself is not supported");
      if (c["penalty"].defined())
        spec.penalty = c["penalty"].positive(0);
      if (c["normals"].defined())
        spec.smooth_normals = c["normals"].choice({"smooth", "facet"}) == "smooth";
      scene.contacts.push_back(spec);
    }
  }
  int constraints = 0;
  for (const BoundaryCondition& bc : scene.boundary)
    if (bc.kind == BoundaryCondition::Kind::uniform_axial and ++constraints > 1)
      throw InputError(bc.where.text() + ": only one uniform_axial condition per scene");

  // time
  const Entry t = top.required("time");
  t.require_map({"end", "step", "max_cutbacks", "cutback_factor", "growth_factor"});
  scene.time.t_end = t.required("end").positive(0);
  scene.time.dt = t.required("step").positive(0);
  if (scene.time.dt > scene.time.t_end)
    t["step"].fail("'" + t["step"].text() + "' is longer than the simulated time");
  scene.time.max_cutbacks = t["max_cutbacks"].integer(8, 0, 40);
  scene.time.cutback_factor = t["cutback_factor"].number(0.5);
  if (!(scene.time.cutback_factor > 0 and scene.time.cutback_factor < 1))
    t["cutback_factor"].fail("'" + t["cutback_factor"].text() + "' must be between 0 and 1");
  scene.time.growth_factor = t["growth_factor"].number(1.5);
  if (!(scene.time.growth_factor >= 1))
    t["growth_factor"].fail("'" + t["growth_factor"].text() + "' must be >= 1");

  // dynamics
  const Entry d = top["dynamics"];
  if (d.defined())
  {
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

  // solver
  const Entry s = top["solver"];
  if (s.defined())
  {
    s.require_map({"linear", "line_search", "rtol", "atol", "max_iterations",
                   "stagnation_window", "linear_rtol", "fbar_cell_unknowns", "root_tolerance",
                   "near_null_space", "reduced_blocks", "petsc"});
    scene.newton.linear_solver = s["linear"].defined()
                                     ? s["linear"].choice(NewtonOptions::linear_solvers())
                                     : "lu";
    if (s["line_search"].defined())
    {
      scene.newton.line_search = s["line_search"].choice(NewtonOptions::line_searches());
      scene.line_search_given = true;
    }
    scene.newton.rtol = s["rtol"].positive(scene.newton.rtol);
    scene.newton.atol = s["atol"].positive(scene.newton.atol);
    scene.newton.max_iterations = s["max_iterations"].integer(25, 1, 1000);
    scene.newton.stagnation_window
        = s["stagnation_window"].integer(scene.newton.stagnation_window, 0, 1000);
    scene.newton.linear_rtol = s["linear_rtol"].positive(scene.newton.linear_rtol);
    scene.newton.fbar_cell_unknowns = s["fbar_cell_unknowns"].flag(true);
    if (s["near_null_space"].defined())
      scene.newton.near_null_space
          = s["near_null_space"].choice(NewtonOptions::near_null_spaces());
    scene.newton.reduced_blocks = s["reduced_blocks"].flag(true);
    scene.root_tolerance = s["root_tolerance"].number(scene.root_tolerance);
    if (!(scene.root_tolerance >= 1e-16 and scene.root_tolerance < 1))
      s["root_tolerance"].fail("'" + s["root_tolerance"].text() + "' must be from 1e-16 "
                               "(round-off; smaller never stops) to below 1");
    if (s["petsc"].defined())
    {
      std::istringstream words(s["petsc"].text());
      for (std::string w; words >> w;)
        scene.petsc_options.push_back(w);
      if (!scene.petsc_options.empty() and scene.petsc_options[0][0] != '-')
        s["petsc"].fail("PETSc options start with '-', e.g. \"-snes_monitor -ksp_type gmres\"");
    }
  }

  // what a checkpoint must match also covers the parameter values (parameter
  // files included) and the data files' contents
  for (const Part& part : scene.parts)
  {
    scene.physics += part.parameters.to_text();
    for (const std::string& path : {part.fibres.path, part.activation_scale.path})
      if (!path.empty())
      {
        std::stringstream data;
        data << std::ifstream(path).rdbuf();
        scene.physics += path + ":" + std::to_string(std::hash<std::string>{}(data.str())) + "\n";
      }
  }

  // output
  const Entry o = top["output"];
  if (o.defined())
  {
    o.require_map({"series", "fields", "fields_every", "plots", "surface", "checkpoint_every"});
    if (o["series"].defined())
    {
      const Entry q = o["series"];
      if (!q.is_sequence())
        q.fail("expected a list of quantities, found " + q.shown());
      std::set<std::string> names;
      for (std::size_t i = 0; i < q.size(); ++i)
      {
        scene.output.series.push_back(read_quantity(q.at(i)));
        if (!names.insert(scene.output.series.back().name).second)
          q.at(i)["name"].fail("two columns named '" + scene.output.series.back().name + "'");
      }
    }
    scene.output.fields = o["fields"].flag(true);
    scene.output.fields_every = o["fields_every"].integer(1, 1, 1000000);
    scene.output.plots = o["plots"].flag(true);
    scene.output.surface = o["surface"].flag(true);
    scene.output.checkpoint_every = o["checkpoint_every"].integer(1, 1, 1000000);
  }
  return scene;
}

Scene read_scene(const std::string& path, const std::vector<std::string>& overrides)
{
  std::ifstream in(path);
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error) or !in)
    throw InputError(path + ": scene file not found");
  std::stringstream text;
  text << in.rdbuf();
  const std::string directory
      = std::filesystem::absolute(path).parent_path().string();
  return parse_scene(text.str(), path, directory, overrides);
}

} // namespace muscle
